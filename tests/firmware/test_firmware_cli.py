"""`artro firmware build|run` (app.cli.firmware) and the exported firmware folder."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from app.assets import builtin_robots_dir
from app.cli.firmware import add_parser as add_firmware_parser
from app.cli.firmware import command as cmd_firmware
from app.firmware.build import export_firmware_folder, memory_use
from app.firmware.closed_loop import LAW_TOLERANCE, ClosedLoopRun
from app.firmware.conformance import ANGLE_TOLERANCE_RAD, Comparison
from app.params.presets import PresetStore, builtin_presets
from hardware.firmware.schema import complete_document
from tests.testing.firmware_support import preset


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="artro")
    add_firmware_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(argv)


def test_exported_folder_builds_with_make_alone(tmp_path: Path) -> None:
    folder = export_firmware_folder(preset("tuned", a_p=0.05), tmp_path / "fw")
    assert (folder / "gen" / "artro_params.h").exists() and (folder / "PROTOCOL.md").exists()
    subprocess.run(["make"], cwd=folder, check=True, capture_output=True)
    flash, sram = memory_use(folder / "build" / "artro.elf")
    assert (folder / "build" / "artro.hex").stat().st_size > 0
    assert 0 < flash < 128 * 1024 and 0 < sram < 4 * 1024
    assert "flash:" in subprocess.run(
        ["make", "-n", "flash"], cwd=folder, check=True, capture_output=True, text=True
    ).stdout.replace("flash:w", "flash:")


def test_a_folder_of_other_files_is_never_written_over(tmp_path: Path) -> None:
    precious = tmp_path / "precious"
    (precious / "src").mkdir(parents=True)
    (precious / "Makefile").write_text("all:\n\techo mine\n", encoding="utf-8")
    with pytest.raises(ValueError, match="holds other files and is not a firmware folder"):
        export_firmware_folder(preset("tuned"), precious)
    assert (precious / "Makefile").read_text(encoding="utf-8") == "all:\n\techo mine\n"
    assert list((precious / "src").iterdir()) == []
    folder = export_firmware_folder(preset("tuned"), tmp_path / "fw")  # a new folder, then
    export_firmware_folder(preset("paper"), folder)  # written again: a folder of its own
    assert '"paper"' in (folder / "parameters.json").read_text(encoding="utf-8")


def test_firmware_run_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    vcd = tmp_path / "walk.vcd"
    args = parse(["firmware", "run", "--params", "paper", "--motion", "0,0.07,0", "--frames",
                  "12", "--json", "--vcd", str(vcd)])  # fmt: skip
    assert cmd_firmware(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"] == 12 and out["pulses_compared"] == 144
    assert out["exact"] + out["one_tick"] == 144 and out["mismatches"] == 0
    assert 0 < out["cycles_per_frame_max"] < 320_000
    assert 0 < out["flash_bytes"] < 128 * 1024 and 0 < out["sram_bytes"] < 4096
    text = vcd.read_text()
    for name in ("OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C", "SEL0", "SEL1", "SEL2"):
        assert f" {name} $end" in text
    # SEL0 rises in the first guard's tick 4900, at the tick's start: 2.45 ms = 24 500 x 100 ns
    assert "$timescale 100ns $end" in text
    assert int(re.search(r"#(\d+)\n1'", text).group(1)) == 24_500


def test_firmware_run_closes_the_loop_with_a_law_on(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A set with a feedback law on: the firmware walks the simulated robot, varied, from its
    emulated sensors, against the model fed the same counts (docs/DESIGN.md §15)."""
    doc = complete_document(preset("tuned", a_p=0.05))
    doc["gait"]["tilt"]["enabled"] = doc["gait"]["damping"]["enabled"] = True
    (tmp_path / "laws.json").write_text(json.dumps(doc))
    argv = ["firmware", "run", "--params", str(tmp_path / "laws.json"), "--frames", "30",
            "--json", "--vary", "imu_tilt_bias_deg=1,gyro_noise_deg_s=0.1"]  # fmt: skip
    assert cmd_firmware(parse(argv)) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pulses_compared"] == 360 and out["mismatches"] == 0 and not out["overrun"]
    assert out["twi_transactions_per_frame"]["min"] == 1 and out["imu_failures"] == 0
    assert out["adc_conversions_per_frame"] == {"min": 8, "max": 8, "mean": 8.0}
    assert out["variation"] == "imu_tilt_bias_deg=1,gyro_noise_deg_s=0.1"
    assert 0 < out["flash_bytes"] < 128 * 1024 and 0 < out["sram_bytes"] < 4096  # as open loop
    # open loop, --vary has nothing to vary: said so, nothing runs
    with pytest.raises(ValueError, match="needs a set with a feedback law on"):
        argv = ["firmware", "run", "--params", "paper", "--frames", "5", "--vary", "fsr_gain=1.1"]
        cmd_firmware(parse(argv))


def test_firmware_build_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cmd_firmware(parse(["firmware", "build", "-o", str(tmp_path / "out")])) == 0
    assert (tmp_path / "out" / "build" / "artro.hex").exists()
    assert "flash" in capsys.readouterr().out


def test_firmware_run_json_prints_nothing_but_the_json() -> None:
    """The emulator's own messages (simavr logs its ELF loading on stdout) stay out of it. No
    --params: the robot's default preset (ArtRo's `robust`, closed-loop), as every command's."""
    artro = Path(sys.executable).with_name("artro")
    run = subprocess.run(
        [str(artro), "firmware", "run", "--frames", "5", "--json"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    said = json.loads(run.stdout)
    assert said["frames"] == 5 and "law_error_max" in said  # robust's laws ran on the MCU


def test_a_fall_ends_what_is_judged_and_a_difference_is_said(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A gyro biased 250 °/s fells the robot at frame 39; after it the attitude estimate parts
    by float32's last bits (2.2e-5 against a tolerance of 2e-5) and the run exited 1 without a
    word. Frames from the fall on are said, not judged (a fall ends every evaluator's run), and
    any failure is named on stderr."""
    doc = complete_document(preset("tuned", a_p=0.05))
    for law in ("tilt", "yaw_rate", "damping", "cop"):
        doc["gait"][law]["enabled"] = True
    (tmp_path / "laws.json").write_text(json.dumps(doc))
    argv = ["firmware", "run", "--params", str(tmp_path / "laws.json"), "--frames", "150",
            "--json", "--vary", "gyro_bias_deg_s=250"]  # fmt: skip
    assert cmd_firmware(parse(argv)) == 0
    said = capsys.readouterr()
    out = json.loads(said.out)
    assert out["ok"] and out["failures"] == [] and said.err == ""
    assert out["fell_at_frame"] is not None and 0 < out["fell_at_frame"] < 150
    assert out["law_error_max"] <= LAW_TOLERANCE and out["law_error_max_fallen"] >= 0.0


def test_what_differs_is_named_with_its_tolerance() -> None:
    run = ClosedLoopRun(
        Comparison(mismatches=["frame 3 OC1A slot 2: 1501 ticks, the model 1500"],
                   max_angle_error_rad=0.5),
        law_error_max=1e-3, overrun=True, fell_at=7,
    )  # fmt: skip
    assert not run.ok
    assert run.failures() == [
        "pulses that differ from the model's: 1 (the first: frame 3 OC1A slot 2: 1501 ticks, "
        "the model 1500)",
        f"the angles differ by up to 0.5 rad (tolerance {ANGLE_TOLERANCE_RAD:g})",
        f"the laws' outputs differ by up to 0.001 (tolerance {LAW_TOLERANCE:g}) before the fall",
        "a plan was late and a frame repeated (the TDM's overrun flag)",
    ]
    assert ClosedLoopRun(Comparison()).failures() == []


def test_a_firmware_of_a_set_it_chose_names_that_set(tmp_path: Path) -> None:
    """Issue 56 item 1: without --params, `firmware build` and `firmware run` took a robot's
    newest tune (a throwaway, in the case seen) and said nothing of it. Both name the set they
    chose and why on standard error; `build` names its set, robot and version beside the
    `make flash` line (also with --params)."""
    raw = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
    (tmp_path / "mine.yaml").write_text(yaml.safe_dump(raw | {"name": "mine"}), encoding="utf-8")
    store = PresetStore(tmp_path / "data", builtin_presets())
    store.save("throwaway", dataclasses.replace(builtin_presets()["tuned"], robot="mine"))
    env = {**os.environ, "ARTRO_DATA_DIR": str(tmp_path / "data")}
    artro = Path(sys.executable).with_name("artro")
    chosen = (
        "no --params: the parameter set 'throwaway' (robot mine, made 20",
        f"the newest set saved for mine (its default preset '{raw['default_preset']}' was tuned "
        "for artro)",
    )
    for action in (["build", "-o", "fw"], ["run", "--frames", "2", "--json"]):
        said = subprocess.run(
            [str(artro), "firmware", *action, "--robot", "mine.yaml"],
            capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600,
        )  # fmt: skip
        assert said.returncode == 0, said.stderr
        assert all(part in said.stderr for part in chosen), said.stderr
    built = subprocess.run(
        [str(artro), "firmware", "build", "--robot", "mine.yaml", "-o", "fw"],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600, check=True,
    ).stdout  # fmt: skip
    assert re.search(
        r"built from the parameter set 'throwaway' \(robot mine, made 20\S+, artro \S+\);.*"
        r"`make -C fw flash` programs it",
        built,
    ), built
