"""`artro firmware build|run|flash --board mega2560-pca9685` (app.cli.firmware,
app.cli.firmware_flash) and the robot description's `board` (docs/BOARDS.md)."""

from __future__ import annotations

import argparse
import json
import re
import shlex
import subprocess
from pathlib import Path

import pytest

from app.cli.firmware import add_parser as add_firmware_parser
from app.cli.firmware import command as cmd_firmware
from app.firmware.build import memory_use
from app.robots import load_description
from app.robots.description import RobotDescription


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="artro")
    add_firmware_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(argv)


def test_build_for_the_mega_writes_its_hex_and_the_upload_command(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "mega_fw"
    args = parse(["firmware", "build", "--board", "mega2560-pca9685", "-o", str(folder)])
    assert cmd_firmware(args) == 0
    out = capsys.readouterr().out
    assert "for the mega2560-pca9685: flash" in out and "of 262144" in out and "of 8192" in out
    (line,) = [ln for ln in out.splitlines() if ln.startswith("upload through the Mega")]
    command = shlex.split(line.split(": ", 1)[1])
    hex_file = (folder / "build" / "artro.hex").resolve()
    assert command == ["avrdude", "-p", "atmega2560", "-c", "wiring", "-P", "PORT", "-b",
                       "115200", "-D", "-U", f"flash:w:{hex_file}:i"]  # fmt: skip
    # the folder alone builds the Mega's firmware again, for the ATmega2560
    subprocess.run(["make", "clean"], cwd=folder, check=True, capture_output=True)
    subprocess.run(["make"], cwd=folder, check=True, capture_output=True)
    flash, sram = memory_use(folder / "build" / "artro.elf")
    assert 0 < flash < 256 * 1024 and 0 < sram < 8 * 1024
    arch = subprocess.run(["avr-objdump", "-f", str(folder / "build" / "artro.elf")],
                          capture_output=True, text=True, check=True).stdout  # fmt: skip
    assert "architecture: avr:6" in arch


def test_an_unknown_board_is_refused_and_the_robot_says_its_own(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_info:
        parse(["firmware", "build", "--board", "uno", "-o", str(tmp_path / "x")])
    assert exit_info.value.code == 2 and not (tmp_path / "x").exists()
    doc = load_description("artro").model_dump()
    assert doc["board"] == "artro-atmega128"  # the default
    with pytest.raises(ValueError, match="'artro-atmega128' or 'mega2560-pca9685'"):
        RobotDescription.model_validate({**doc, "board": "uno"})
    assert RobotDescription.model_validate({**doc, "board": "mega2560-pca9685"}).board == (
        "mega2560-pca9685"
    )


def test_run_on_the_mega_compares_every_pulse(capsys) -> None:
    args = parse(["firmware", "run", "--board", "mega2560-pca9685", "--frames", "40", "--json"])
    assert cmd_firmware(args) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["ok"] and summary["board"] == "mega2560-pca9685" and summary["pulses"] >= 12 * 39
    assert summary["pulse_error_max_us"] <= summary["step_us"]


def _pwm_changes(vcd: Path) -> list[str]:
    """The VCD's value changes (its header, with the date, left out)."""
    return vcd.read_text(encoding="ascii").split("$enddefinitions $end")[1].splitlines()


def test_a_varied_mega_run_walks_the_varied_robot(tmp_path: Path, capsys) -> None:
    """`--vary` on the Mega: the robot and its IMU varied, every pulse still the model's (fed
    what the firmware read), and the laws' answer to the IMU's tilt on the PCA9685's lines."""
    runs = {}
    for vary in ("imu_tilt_bias_deg=3", None):
        vcd = tmp_path / f"{vary}.vcd"
        argv = ["firmware", "run", "--board", "mega2560-pca9685", "--frames", "30", "--json",
                "--vcd", str(vcd)] + (["--vary", vary] if vary else [])  # fmt: skip
        assert cmd_firmware(parse(argv)) == 0
        runs[vary] = (json.loads(capsys.readouterr().out), _pwm_changes(vcd))
    (varied, varied_lines), (nominal, nominal_lines) = runs.values()
    assert varied["ok"] and varied["variation"] == "imu_tilt_bias_deg=3"
    assert nominal["variation"] == "nominal"
    assert varied["pulses"] == nominal["pulses"] >= 12 * 29
    assert varied_lines != nominal_lines  # the tilt law answered the biased IMU
    # a push after the run's end is refused as the ATmega128's run refuses it
    with pytest.raises(ValueError, match="push_time_s"):
        cmd_firmware(parse(["firmware", "run", "--board", "mega2560-pca9685", "--frames", "10",
                            "--vary", "push_n_s=0.5,push_time_s=5"]))  # fmt: skip


def test_the_megas_vcd_carries_its_channels_and_its_bus(tmp_path: Path, capsys) -> None:
    """`--vcd`: PWM0..PWM11 and a line per part on the bus, high while its transaction runs."""
    vcd = tmp_path / "mega.vcd"
    args = parse(["firmware", "run", "--board", "mega2560-pca9685", "--frames", "12", "--json",
                  "--vcd", str(vcd)])  # fmt: skip
    assert cmd_firmware(args) == 0
    capsys.readouterr()
    text = vcd.read_text(encoding="ascii")
    names = dict(re.findall(r"^\$var wire 1 (\S) (\S+) \$end$", text, re.MULTILINE))
    code = {name: c for c, name in names.items()}
    assert list(code) == [f"PWM{n}" for n in range(12)] + ["I2C_PCA9685", "I2C_MPU6050"]
    rises: dict[str, list[int]] = {}
    widths: dict[str, list[int]] = {}
    time = 0
    for line in text.split("$enddefinitions $end")[1].splitlines():
        if line.startswith("#"):
            time = int(line[1:])
        elif line[:1] in "01" and len(line) == 2 and time > 0:
            name = names[line[1]]
            if line[0] == "1":
                rises.setdefault(name, []).append(time)
            elif rises.get(name):
                widths.setdefault(name, []).append(time - rises[name][-1])
    # a write to the PCA9685 and a read of the IMU in each frame; servo pulses of 0.6-2.4 ms
    assert len(rises["I2C_PCA9685"]) in (11, 12) and len(rises["I2C_MPU6050"]) in (11, 12)
    for n in range(12):
        assert len(widths[f"PWM{n}"]) >= 10
        assert all(6_000 <= w <= 24_000 for w in widths[f"PWM{n}"])  # 100 ns units


def test_flash_runs_avrdude_and_says_when_no_board_answers(tmp_path: Path, capsys) -> None:
    """No hardware here: a port that is not there is refused before avrdude; /dev/null is a
    character device with no bootloader behind it, and the real avrdude says so (exit 1)."""
    build = parse(["firmware", "build", "--board", "mega2560-pca9685", "-o", str(tmp_path / "fw")])
    cmd_firmware(build)
    hex_file = tmp_path / "fw" / "build" / "artro.hex"
    flash = ["firmware", "flash", "--board", "mega2560-pca9685", "--hex", str(hex_file)]
    with pytest.raises(ValueError, match="no serial port there"):
        cmd_firmware(parse([*flash, "--port", str(tmp_path / "ttyACM9")]))
    capsys.readouterr()
    code = cmd_firmware(parse([*flash, "--port", "/dev/null"]))
    captured = capsys.readouterr()
    assert code == 1
    assert captured.out.startswith("avrdude -p atmega2560 -c wiring -P /dev/null -b 115200 -D")
    assert "avrdude could not program the mega2560-pca9685 on /dev/null" in captured.err
    with pytest.raises(SystemExit):
        parse(["firmware", "flash", "--port", "/dev/null", "--hex", str(tmp_path / "none.hex")])
