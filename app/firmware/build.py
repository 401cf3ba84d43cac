"""Building the ArtRo firmware (avr-gcc, its generated headers for a parameter set) and the
simavr harness library (cc), each cached by a hash of its inputs (docs/DESIGN.md §5)."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import tempfile
import threading
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import hardware.firmware as firmware_package
from app.robots.description_parts import Board
from app.robots.model import RobotModel
from gait import ARTRO_LEG, LegGeometry
from hardware import ChannelMap, ServoCalibration, TdmConfig
from hardware.firmware import HEADER_NAME, c_header
from hardware.firmware.schema import (
    ARTRO_FSR_POSITIONS_M,
    FIRMWARE_ENGINE,
    SCHEMA_HEADER_NAME,
    c_schema_header,
    complete_document,
)
from hardware.firmware.wire import WIRE_HEADER_NAME, c_wire_header

FIRMWARE_DIR = Path(firmware_package.__file__).resolve().parent
SOURCE_DIR = FIRMWARE_DIR / "src"
MAKEFILE = FIRMWARE_DIR / "Makefile"
HARNESS_SOURCE = Path(__file__).resolve().parent / "harness.c"
#: compiled with it: simavr's corrections, the balance sensors, the Mega board's I2C bus (the
#: PCA9685 part, the monitor)
HARNESS_SOURCES = tuple(
    HARNESS_SOURCE.with_name(name)
    for name in ("harness.c", "harness_fixes.c", "harness_sensors.c", "harness_i2c.c")
)
#: what they include (not compiled alone, but in the library's hash)
HARNESS_HEADERS = (HARNESS_SOURCE.with_name("harness.h"),)
TOOLS = ("avr-gcc", "avr-objcopy", "avr-size", "make")
#: the boards the firmware builds for (the Makefile's BOARD, docs/BOARDS.md), the first the default
BOARDS: tuple[str, ...] = typing.get_args(Board)
DEFAULT_BOARD = BOARDS[0]
#: flash and SRAM of each board's MCU, bytes
BOARD_MEMORY = {
    "artro-atmega128": (128 * 1024, 4 * 1024),
    "mega2560-pca9685": (256 * 1024, 8 * 1024),
}
#: the MCU simavr emulates for each board
BOARD_MCU = {"artro-atmega128": "atmega128", "mega2560-pca9685": "atmega2560"}
#: the boards that reset as their serial port opens (an Arduino's DTR), and how long their
#: bootloader runs before the firmware answers, s (docs/BOARDS.md)
BOARD_BOOTLOADER_S = {"mega2560-pca9685": 1.0}


class BuildError(RuntimeError):
    """A tool is missing or a compile failed; the message carries the tool's output."""


@dataclass(frozen=True)
class FirmwareBuild:
    """A built firmware: the ELF and HEX, and its memory use as avr-size reports it."""

    directory: Path
    elf: Path
    hex: Path
    flash_bytes: int  # .text + .data (the initial values live in flash)
    sram_bytes: int  # .data + .bss + .noinit, without the stack
    flash_size: int = 128 * 1024
    sram_size: int = 4 * 1024
    board: str = DEFAULT_BOARD


def cache_dir() -> Path:
    """$ARTRO_CACHE_DIR, else $XDG_CACHE_HOME/artro-gait-studio, else ~/.cache/artro-gait-studio."""
    if os.environ.get("ARTRO_CACHE_DIR"):
        return Path(os.environ["ARTRO_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "artro-gait-studio"


def missing_tools(tools: tuple[str, ...] = TOOLS) -> list[str]:
    return [tool for tool in tools if shutil.which(tool) is None]


def _run(command: list[str], cwd: Path) -> str:
    """The command's output; BuildError if it fails, its compiler errors said first (a message
    cut short keeps them), then the command and its whole output."""
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    if result.returncode != 0:
        output = f"{result.stdout}{result.stderr}"
        lines = output.strip().splitlines()
        errors = [line.strip() for line in lines if "error" in line.lower()] or lines[-3:]
        raise BuildError(
            f"{Path(command[0]).name} failed: {' | '.join(errors[:4])}\n"
            f"command: {' '.join(command)}\n{output}"
        )
    return result.stdout


def _write_whole(path: Path, text: str) -> None:
    """`text` into `path`, replaced in one step: a build reading it meanwhile sees the old file
    or the new one, never a file cut short (two builds of one set share their folder)."""
    part = path.with_name(f".{path.name}.{os.getpid()}-{threading.get_ident()}")
    part.write_text(text, encoding="ascii")
    os.replace(part, path)


def generated_headers(
    doc: dict[str, Any],
    *,
    calibration: ServoCalibration | None = None,
    tdm: TdmConfig | None = None,
    geometry: LegGeometry = ARTRO_LEG,
    fsr_positions_m: Sequence[Sequence[float]] = ARTRO_FSR_POSITIONS_M,
) -> dict[str, str]:
    """{file name: text} of the generated headers (parameters, schema, wire layouts) for a
    parameter-set document (fields left out take the schema's defaults) on a robot's legs and
    sole force sensors; ValueError if it names an engine the firmware does not run."""
    tdm = tdm or TdmConfig()
    full = complete_document(doc)  # a define for every id of artro_schema.h
    if full["gait"]["engine"] != FIRMWARE_ENGINE:
        raise ValueError(
            f"the firmware runs the {FIRMWARE_ENGINE} gait engine; this parameter set names "
            f"{full['gait']['engine']!r} (docs/DESIGN.md §4)"
        )
    params_h = c_header(
        full,
        calibration=calibration or ServoCalibration.default(),
        channel_map=tdm.channel_map or ChannelMap.default(),
        select_change_ticks=tdm.select_change_ticks,
    )
    schema_h = c_schema_header(geometry, fsr_positions_m)
    return {HEADER_NAME: params_h, SCHEMA_HEADER_NAME: schema_h, WIRE_HEADER_NAME: c_wire_header()}


def source_files() -> dict[str, bytes]:
    """The firmware's C sources and Makefile: {relative path: content}."""
    files = {f"src/{p.name}": p.read_bytes() for p in sorted(SOURCE_DIR.iterdir()) if p.is_file()}
    files["Makefile"] = MAKEFILE.read_bytes()
    return files


def _digest(parts: Mapping[str, bytes | str]) -> str:
    h = hashlib.sha256()
    for name in sorted(parts):
        data = parts[name]
        h.update(name.encode() + b"\0" + (data.encode() if isinstance(data, str) else data) + b"\0")
    return h.hexdigest()[:16]


def memory_use(elf: Path) -> tuple[int, int]:
    """(flash bytes, SRAM bytes) from `avr-size -A`: .text + .data, and .data + .bss + .noinit."""
    out = _run(["avr-size", "-A", str(elf)], elf.parent)
    sizes = {m[0]: int(m[1]) for m in re.findall(r"^(\.\w+)\s+(\d+)\s+\d+", out, re.MULTILINE)}
    flash = sizes.get(".text", 0) + sizes.get(".data", 0)
    sram = sizes.get(".data", 0) + sizes.get(".bss", 0) + sizes.get(".noinit", 0)
    return flash, sram


def build_firmware(
    doc: dict[str, Any],
    *,
    calibration: ServoCalibration | None = None,
    tdm: TdmConfig | None = None,
    geometry: LegGeometry = ARTRO_LEG,
    fsr_positions_m: Sequence[Sequence[float]] = ARTRO_FSR_POSITIONS_M,
    out_dir: Path | None = None,
    defines: dict[str, str] | None = None,
    board: str = DEFAULT_BOARD,
) -> FirmwareBuild:
    """Generate the headers for `doc`, compile, link; cached unless `out_dir` is given.

    Args:
        doc: a parameter-set document (`ParameterSet.to_dict()`); its values are the defaults
            the firmware boots with.
        calibration, tdm: servo calibration and TDM set-up (default: uncalibrated, default map,
            select change at 4900 ticks); geometry: the robot's leg (`RobotModel.geometry`);
            fsr_positions_m: its sole force sensors (`RobotModel.fsr_positions_m`).
        out_dir: build here (gen/, build/) instead of the cache.
        defines: extra -D options, e.g. {"ARTRO_BOOT_STATE": "1"}.
        board: one of BOARDS (docs/BOARDS.md).

    Raises:
        BuildError: a tool is missing or the compile failed.
    """
    check_board(board)
    if missing := missing_tools():
        raise BuildError(f"missing tools: {', '.join(missing)} (install gcc-avr, avr-libc, make)")
    headers = generated_headers(
        doc, calibration=calibration, tdm=tdm, geometry=geometry, fsr_positions_m=fsr_positions_m
    )
    extra = " ".join(f"-D{k}={v}" for k, v in sorted((defines or {}).items()))
    if out_dir is None:
        parts: dict[str, bytes | str] = {**source_files(), **headers, "cflags": extra}
        if board != DEFAULT_BOARD:  # the ATmega128's key: its sources, headers and flags alone
            parts["board"] = board
        key = _digest(parts)
        out_dir = cache_dir() / "firmware" / key
    out_dir = Path(out_dir).resolve()
    elf, hexfile = out_dir / "build" / "artro.elf", out_dir / "build" / "artro.hex"
    if not (elf.exists() and hexfile.exists()):
        gen = out_dir / "gen"
        gen.mkdir(parents=True, exist_ok=True)
        for name, text in headers.items():
            _write_whole(gen / name, text)
        with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
            _run(
                [
                    "make",
                    "-f",
                    str(MAKEFILE),
                    f"SRC_DIR={SOURCE_DIR}",
                    f"GEN={gen}",
                    f"BUILD={tmp}",
                    f"EXTRA_CFLAGS={extra}",
                    f"BOARD={board}",
                ],
                out_dir,
            )
            (out_dir / "build").mkdir(exist_ok=True)
            for name in ("artro.elf", "artro.hex"):
                os.replace(Path(tmp) / name, out_dir / "build" / name)  # atomic for other runs
    flash, sram = memory_use(elf)
    _write_whole(out_dir / "build" / "size.json", json.dumps({"flash": flash, "sram": sram}))
    flash_size, sram_size = BOARD_MEMORY[board]
    return FirmwareBuild(out_dir, elf, hexfile, flash, sram, flash_size, sram_size, board)


def check_board(board: str) -> str:
    """`board` if the firmware builds for it; ValueError saying which it builds for."""
    if board not in BOARDS:
        raise ValueError(f"board {board!r}: the firmware builds for {', '.join(BOARDS)}")
    return board


def harness_library() -> Path:
    """The simavr harness as a shared library, compiled on first use."""
    if missing := missing_tools(("cc",)):
        raise BuildError(f"missing tools: {', '.join(missing)}")
    sources = {path.name: path.read_bytes() for path in (*HARNESS_SOURCES, *HARNESS_HEADERS)}
    target = cache_dir() / "mcu" / f"libartro_mcu-{_digest(sources)}.so"
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        out = Path(tmp) / target.name
        command = ["cc", "-shared", "-fPIC", "-O2", "-o", str(out), *map(str, HARNESS_SOURCES)]
        _run([*command, "-lsimavr", "-lelf"], Path(tmp))
        os.replace(out, target)
    return target


def export_firmware_folder(
    doc: dict[str, Any],
    out_dir: Path | str,
    *,
    calibration: ServoCalibration | None = None,
    tdm: TdmConfig | None = None,
    geometry: LegGeometry = ARTRO_LEG,
    fsr_positions_m: Sequence[Sequence[float]] = ARTRO_FSR_POSITIONS_M,
    board: str = DEFAULT_BOARD,
) -> Path:
    """A self-contained firmware folder for one parameter set: `make` builds it, `make flash`
    programs the robot (avrdude). Contents: src/ (the C sources), gen/ (the two generated
    headers), Makefile, PROTOCOL.md, README.md, parameters.json (the document). Returns the
    folder. ValueError for a folder that holds other files and no parameters.json (not one
    this wrote before): its Makefile and src/ would be written over."""
    out = Path(out_dir)
    if out.is_dir() and any(out.iterdir()) and not (out / "parameters.json").is_file():
        raise ValueError(
            f"{out} holds other files and is not a firmware folder written before (no "
            "parameters.json): its Makefile and src/ would be written over; give a new or "
            "empty folder"
        )
    (out / "src").mkdir(parents=True, exist_ok=True)
    (out / "gen").mkdir(exist_ok=True)
    for name, data in source_files().items():
        if name == "Makefile":  # its BOARD the folder's board (a `make BOARD=...` still rules)
            data = f"BOARD ?= {check_board(board)}\n".encode() + data
        (out / name).write_bytes(data)
    for doc_name in ("PROTOCOL.md", "README.md"):
        shutil.copyfile(FIRMWARE_DIR / doc_name, out / doc_name)
    headers = generated_headers(
        doc, calibration=calibration, tdm=tdm, geometry=geometry, fsr_positions_m=fsr_positions_m
    )
    for name, text in headers.items():
        (out / "gen" / name).write_text(text, encoding="ascii")
    (out / "parameters.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return out


def wiring(robot: RobotModel) -> dict[str, Any]:
    """What the firmware takes from a robot (`build_firmware`'s keywords): calibration, TDM map
    leg geometry and sole force sensors. ValueError for a robot of bus servos: the firmware
    sends TDM-PWM pulses, which they do not take (docs/BUS.md)."""
    hardware = robot.hardware()
    if hardware.bus is not None:
        servo = robot.description.joint_servo("l_knee")
        raise ValueError(
            f"robot {robot.name!r} has bus servos ({servo}, {hardware.bus.protocol}): the "
            "ATmega128 firmware drives TDM-PWM pulses, which they do not take; drive it from "
            "the host over its bus (docs/BUS.md)"
        )
    return {
        "calibration": hardware.calibration,
        "tdm": hardware.tdm,
        "geometry": robot.geometry,
        "fsr_positions_m": tuple(map(tuple, robot.fsr_positions_m.tolist())),
    }
