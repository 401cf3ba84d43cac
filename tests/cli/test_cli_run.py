"""`artro run` as a user calls it: the installed console script, real simulation."""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from app.params.document import project_version

ARTRO = shutil.which("artro", path=str(Path(sys.executable).parent)) or "artro"


def artro(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([ARTRO, *args], capture_output=True, text=True, timeout=300)


def test_walking_on_the_spot_for_30_s_stands_and_does_not_drift():
    out = artro("run", "--motion", "0,0,0", "--duration", "30", "--json")
    assert out.returncode == 0, out.stderr
    m = json.loads(out.stdout)
    expected = {
        "fell",
        "forward_cm_s",
        "lateral_cm_s",
        "turn_deg_s",
        "predicted_turn_deg_s",
        "path_error_cm",
        "gyro_rms",
        "sim_s",
        "wall_s",
        "rtf",
    }
    assert expected <= set(m)
    assert m["fell"] is False
    assert (m["forward_cm_s"] ** 2 + m["lateral_cm_s"] ** 2) ** 0.5 < 0.5
    assert m["sim_s"] == pytest.approx(30.0)


@pytest.mark.parametrize("as_json", [True, False])
def test_a_run_whose_robot_falls_exits_1_so_a_script_can_tell(as_json):
    """It exited 0 whether the robot walked or fell: only the text said so. (`robust` falls at
    this motion within 3 s; `robust-2` and `robust-3` have walked it.)"""
    motion = ["--params", "robust", "--motion", "a_p=0.3,a_r=0.3", "--duration", "3", "--warmup",
              "1"]  # fmt: skip
    out = artro("run", *motion, *(["--json"] if as_json else []))
    assert out.returncode == 1, out.stderr
    assert "artro run: fell at" in out.stderr and "Traceback" not in out.stderr
    assert json.loads(out.stdout)["fell"] if as_json else "FELL after" in out.stdout


def test_the_exit_status_of_a_fall_is_in_the_help():
    out = artro("run", "--help")
    assert out.returncode == 0
    assert "exit status: 0 the robot walked the whole run, 1 it fell" in out.stdout


def test_human_summary_and_param_file(tmp_path):
    pset = {"name": "slow", "motion": {"a_p": 0.05}, "gait": {"clock": {"freq_hz": 0.8}}}
    path = tmp_path / "slow.json"
    path.write_text(json.dumps(pset))
    out = artro("run", "--params", str(path), "--duration", "3", "--warmup", "1")
    assert out.returncode == 0, out.stderr
    assert "parameter set 'slow'" in out.stdout and "a_p=0.05" in out.stdout
    assert "real time" in out.stdout
    assert re.search(r"servo load: peak \d+\.\d\d N m at \w+, \d+% of its stall torque", out.stdout)


def test_the_servo_load_is_said_as_measured_against_the_stall_torque():
    """It said "largest required servo torque (eq 1, sf 0.2)": 1.2 x a peak that cannot pass
    the stall torque, the same words as `robot check`'s static eq (1) and other numbers."""
    from app.cli.run import servo_load_line
    from app.robots.model import RobotModel

    robot = RobotModel.load()
    names = [robot.model.actuator(i).name for i in range(robot.model.nu)]
    stall = robot.model.actuator_forcerange[:, 1]
    peaks = [0.5 * s for s in stall]
    peaks[3] = stall[3]
    limits = [0.0] * robot.model.nu
    limits[3], limits[9] = 0.25, 0.1
    line = servo_load_line(robot, names, {"peak_torque_nm": peaks, "at_limit_share": limits})
    assert line == (
        f"servo load: peak {stall[3]:.2f} N m at {names[3]}, 100% of its stall torque; at their "
        f"limit (share of frames): {names[3]} 25%, {names[9]} 10%"
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--motion", "0,0"], "expected three numbers"),
        (["--motion", "0,nan,0"], "expected three numbers"),
        (["--motion", "0,0.9,0"], "allowed: -0.3 to 0.3"),
        (["--ca", "2"], "--ca must be -0.5 to 0.5"),
        (["--params", "/nonexistent/p.json"], "No such file"),
        (["--duration", "-1"], "duration must be > 0"),
    ],
)
def test_bad_input_is_a_clear_error(args, message):
    out = artro("run", *args)
    assert out.returncode == 2
    assert message in out.stderr
    assert "Traceback" not in out.stderr


def test_bad_param_file_names_the_problem(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"gait": {"swing": {"speed": 2}}}))
    out = artro("run", "--params", str(path), "--duration", "1")
    assert out.returncode == 2
    assert "unknown field swing.speed" in out.stderr
    path.write_text("{not json")
    out = artro("run", "--params", str(path))
    assert out.returncode == 2 and "bad.json: malformed JSON at line 1, column 2" in out.stderr


@pytest.mark.parametrize("fmt", ["json", "yaml", "c"])
def test_export_writes_each_format(tmp_path, fmt):
    source = tmp_path / "in.json"
    source.write_text(json.dumps({"name": "brisk", "motion": {"a_p": 0.05}}))
    target = tmp_path / f"out.{fmt}"
    out = artro("export", "--format", fmt, "--params", str(source), "-o", str(target))
    assert out.returncode == 0, out.stderr
    text = target.read_text()
    if fmt == "c":
        assert "#define ARTRO_MOTION_A_P 0.05f" in text
    else:
        assert "brisk" in text and "0.05" in text
    assert artro("export", "--format", "pdf").returncode == 2


def test_negative_values_are_values_not_options():
    """`--motion -0.1,0,0` steps to the left (a_r < 0): argparse alone reads it as an option."""
    out = artro(
        "run", "--motion", "-0.1,0,0", "--ca", "-0.05", "--duration", "6", "--warmup", "2", "--json"
    )
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["lateral_cm_s"] > 0.5  # left is + in the measured frame


@pytest.mark.parametrize("command", ["serve", "run", "export", "bench", "tune"])
def test_every_subcommand_has_help_with_an_example(command):
    out = artro(command, "--help")
    assert out.returncode == 0, out.stderr
    assert "examples:" in out.stdout and f"artro {command} " in out.stdout.split("examples:")[1]


@pytest.mark.parametrize(
    ("flags", "view"),
    [
        ([], "3D view alone: http://localhost:8080, "),
        (["--viser-port", "0"], "3D view alone: a free port, GET /api/health names it, "),
        (["--no-viewer"], ""),
    ],
    ids=["default", "any port", "no viewer"],
)
def test_the_serve_banner_names_the_3d_view_only_where_there_is_one(flags, view):
    from app.cli import build_parser
    from app.cli.serve import banner

    args = build_parser().parse_args(["serve", *flags])
    page = "http://localhost:8000"
    assert banner(args) == f"ArtRo Gait Studio: {page}  ({view}API docs: {page}/docs)"


def test_serve_on_a_taken_port_says_so_before_it_names_the_page(tmp_path, capsys):
    """It printed the page's URL, then uvicorn's raw "address already in use" (exit 3)."""
    import socket

    from app.cli import main

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(SystemExit) as ended:
            main(["serve", "--port", str(port), "--no-viewer", "--data-dir", str(tmp_path)])
    said = capsys.readouterr()
    assert ended.value.code == 2 and said.out == ""
    assert said.err.startswith(f"artro serve: error: --port {port} on 127.0.0.1 is taken (")
    assert said.err.rstrip().endswith("give another --port")


def test_artro_version_names_the_package_and_its_version():
    out = artro("--version")
    assert out.returncode == 0 and out.stdout.strip() == f"artro-gait-studio {project_version()}"


def test_ctrl_c_while_the_commands_load_is_one_line(monkeypatch, capsys):
    """The commands' modules take ~2 s to load; a Ctrl-C then printed a traceback."""
    import app.cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(app.cli, "build_parser", interrupted)
    assert app.cli.main(["run"]) == 130
    assert capsys.readouterr().err == "artro: interrupted\n"


def test_a_taken_3d_view_port_moves_on_past_the_pages_own(capsys):
    """viser moved a taken port on to the next, which could be the page's own --port: the page
    then could not listen (exit 3) and the banner named the taken port. The CLI picks the 3D
    view's port itself now, never the page's, before the banner."""
    import socket

    from app.cli.serve import bind_error, viser_port_for

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        asked = taken.getsockname()[1]
        port = viser_port_for("127.0.0.1", asked, page_port=asked + 1)
        assert port not in (asked, asked + 1) and bind_error("127.0.0.1", port) is None
        assert f"port {asked} is taken; the 3D view alone is on {port}" in capsys.readouterr().err
        assert viser_port_for("127.0.0.1", 0, asked) == 0  # any free port: viser's choice


def test_a_reader_that_stops_early_ends_the_command_quietly():
    """`artro run | head -1`: the pipe closed before the command wrote; it said "error: [Errno
    32] Broken pipe" (exit 2). It now ends as a process its pipe ended does: 141, no message."""
    proc = subprocess.Popen([ARTRO, "robot", "show", "artro"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    proc.stdout.close()  # long before the command (~1 s to start) writes
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141 and err == ""
