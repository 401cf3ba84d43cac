"""PROTOCOL.md's fixed layouts, declared once (docs/decisions/0063-wire-layouts-declared-once.md):
each message's ordered fields (name, C type, count, meaning, the firmware's source). From them:
`artro_wire.h` (offsets, `wire_pack_<name>()`), the host's struct formats and field names
(app/firmware/protocol.py) and PROTOCOL.md's tables (`python -m hardware.firmware.wire
--write-docs`; `--check` exits 1 when they are stale)."""

from __future__ import annotations

import argparse
import re
import struct
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

WIRE_HEADER_NAME = "artro_wire.h"
_LVALUE = re.compile(r"[A-Za-z_]\w*((\.|->)[A-Za-z_]\w*)*")
PROTOCOL_MD = Path(__file__).resolve().parent / "PROTOCOL.md"
#: C type: (struct code, bytes, PROTOCOL.md's name)
C_TYPES = {
    "uint8_t": ("B", 1, "u8"),
    "int8_t": ("b", 1, "i8"),
    "uint16_t": ("H", 2, "u16"),
    "int16_t": ("h", 2, "i16"),
    "uint32_t": ("I", 4, "u32"),
    "float": ("f", 4, "f32"),
}


@dataclass(frozen=True)
class Field:
    """One field of a payload: `count` values of `ctype`, taken in C from `source` (an lvalue of
    that type and size, or for a single value any expression, cast to `ctype`)."""

    name: str  # the host's field name (app/firmware/protocol.py)
    ctype: str
    count: int
    what: str  # PROTOCOL.md's words
    source: str

    @property
    def size(self) -> int:
        return C_TYPES[self.ctype][1] * self.count

    @property
    def code(self) -> str:
        return f"{self.count if self.count > 1 else ''}{C_TYPES[self.ctype][0]}"

    def wire_type(self, times: str = "×") -> str:
        name = C_TYPES[self.ctype][2]
        return f"{self.count} {times} {name}" if self.count > 1 else name

    @property
    def is_lvalue(self) -> bool:
        """Whether `source` names a variable or member (its size is then checked in C)."""
        return _LVALUE.fullmatch(self.source) is not None


@dataclass(frozen=True)
class Layout:
    """A message's payload: its fields in wire order, little-endian, packed."""

    name: str  # PROTOCOL.md's message name, e.g. SENSORS
    type_code: int
    fields: tuple[Field, ...]
    includes: tuple[str, ...] = ()  # the firmware headers its sources need
    params: str = ""  # what `wire_pack_<name>` takes after `p`, when sources are a sender's locals

    @property
    def size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fields)

    @property
    def codec(self) -> struct.Struct:
        return struct.Struct("<" + "".join(f.code for f in self.fields))

    def offsets(self) -> list[int]:
        out, at = [], 0
        for f in self.fields:
            out.append(at)
            at += f.size
        return out

    def unpack(self, payload: bytes) -> dict[str, Any]:
        """{field name: value}, a tuple for a field of several values; struct.error if the
        payload is not `size` bytes."""
        values, out = self.codec.unpack(payload), {}
        at = 0
        for f in self.fields:
            out[f.name] = tuple(values[at : at + f.count]) if f.count > 1 else values[at]
            at += f.count
        return out


_LAW_SWITCHES = (
    "(SWITCH(TILT_ENABLED) | SWITCH(YAW_RATE_ENABLED) << 1 | SWITCH(DAMPING_ENABLED) << 2"
    " | SWITCH(COP_ENABLED) << 3 | SWITCH(TIMING_ENABLED) << 4)"
)

# fmt: off
SENSORS = Layout(
    "SENSORS",
    0x88,
    (
        Field("frame", "uint32_t", 1, "the frame the laws corrected", "g_law_frame"),
        Field("status", "uint8_t", 1, "status: the SENSORS status bits below", "g_sensor_status"),
        Field("imu_failures", "uint8_t", 1, "IMU failures since boot, 255 at most",
              "g_imu_failures"),
        Field("laws", "uint8_t", 1,
              "laws on: bit 0 tilt, 1 yaw rate, 2 damping, 3 CoP, 4 step timing", _LAW_SWITCHES),
        Field("support", "int8_t", 1, "support foot: 0 left, 1 right, −1 none",
              "g_law_output.support"),
        Field("gyro_offset", "int16_t", 3, "gyro offsets x, y, z (the boot calibration, counts)",
              "g_gyro_offset"),
        Field("accel_raw", "int16_t", 3, "accelerometer x, y, z (raw counts)",
              "g_sensor_raw.accel"),
        Field("gyro_raw", "int16_t", 3, "gyro x, y, z (raw counts, before the offset)",
              "g_sensor_raw.gyro"),
        Field("adc", "uint16_t", 8, "ADC: left foot front-left, front-right, back-left, "
              "back-right, then the right foot's", "g_sensor_raw.adc"),
        Field("attitude_rad", "float", 2, "attitude estimate pitch, roll (rad)",
              "g_law_output.attitude"),
        Field("tilt_rad", "float", 2, "tilt trim pitch, roll (rad)", "g_law_output.tilt"),
        Field("a_y_delta", "float", 1, "the yaw-rate loop's change of a_y",
              "g_law_output.a_y_delta"),
        Field("cop_rad", "float", 2, "CoP correction: the support foot's ankle pitch, roll (rad)",
              "g_law_output.cop"),
    ),
    includes=("laws.h", "params.h", "sensors.h"),
)
# fmt: on

# fmt: off
TELEMETRY = Layout(
    "TELEMETRY",
    0x86,
    (
        Field("frame", "uint32_t", 1, "the frame of the plan sent last", "plan->frame"),
        Field("phase_rad", "float", 1, "the walking clock's phase φ_Trunk (rad)", "phase"),
        Field("ocr", "uint16_t", 12, "OCR of each servo's pulse, in the gait's joint order",
              "plan->servo_ocr"),
        Field("saturated", "uint16_t", 1, "bit i: servo i clipped", "plan->saturated"),
        Field("flags", "uint8_t", 1, "flags: the TELEMETRY flags below", "flags"),
        Field("state", "uint8_t", 1, "state: the states below", "plan->state"),
    ),
    includes=("plan.h",),
    params="const plan_t *plan, float phase, uint8_t flags",
)
# fmt: on

#: the declared layouts, in PROTOCOL.md's order
LAYOUTS: tuple[Layout, ...] = (TELEMETRY, SENSORS)


def _c_name(layout: Layout, *parts: str) -> str:
    return "_".join(["ARTRO_WIRE", layout.name, *(p.upper() for p in parts)])


def _c_layout(layout: Layout) -> list[str]:
    lower = layout.name.lower()
    lines = [f"/* ---- {layout.name} (0x{layout.type_code:02X}) ---- */"]
    lines.append(f"#define {_c_name(layout, 'BYTES')} {layout.size}u")
    for f, at in zip(layout.fields, layout.offsets(), strict=True):
        lines.append(f"#define {_c_name(layout, f.name):<40} {at}u /* {f.wire_type('x')} */")
    params = f", {layout.params}" if layout.params else ""
    lines += [
        f"/* the payload of {layout.name} from the firmware's state, into p[{layout.size}] */",
        f"static inline void wire_pack_{lower}(uint8_t *p{params})",
        "{",
    ]
    for f in layout.fields:
        if f.is_lvalue:
            lines.append(
                f'    _Static_assert(sizeof({f.source}) == {f.size}, "{f.source} is not '
                f"{layout.name}'s {f.wire_type('x')} {f.name} (hardware/firmware/wire.py)\");"
            )
    for f in layout.fields:
        offset = _c_name(layout, f.name)
        if f.count > 1:
            lines.append(f"    memcpy(&p[{offset}], {f.source}, {f.size});")
        elif f.size == 1:
            lines.append(f"    p[{offset}] = (uint8_t)({f.source});")
        else:
            lines.append(f"    {{ const {f.ctype} v = ({f.ctype})({f.source});")
            lines.append(f"      memcpy(&p[{offset}], &v, {f.size}); }}")
    return [*lines, "}"]


def c_wire_header(layouts: Sequence[Layout] = LAYOUTS) -> str:
    """The include-guarded header `artro_wire.h`: per layout its size, each field's offset
    (`ARTRO_WIRE_<MSG>_<FIELD>`), size checks of its sources, and `wire_pack_<msg>(p)`."""
    includes = sorted({name for layout in layouts for name in layout.includes})
    lines = [
        f"/* {WIRE_HEADER_NAME} -- the payloads of PROTOCOL.md's fixed-layout messages.",
        " * Generated from hardware/firmware/wire.py; do not edit by hand. */",
        "#ifndef ARTRO_WIRE_H",
        "#define ARTRO_WIRE_H",
        "",
        "#include <stdint.h>",
        "#include <string.h>",
        "",
        *(f'#include "{name}"' for name in includes),
    ]
    for layout in layouts:
        lines += ["", *_c_layout(layout)]
    return "\n".join([*lines, "", "#endif /* ARTRO_WIRE_H */"]) + "\n"


def _md(text: str) -> str:
    return text.replace("|", "\\|")


def protocol_tables(layouts: Sequence[Layout] = LAYOUTS) -> str:
    """PROTOCOL.md's generated part: one table per layout, each field's offset, type, meaning."""
    parts = []
    for layout in layouts:
        rows = [
            f"**{layout.name}** (0x{layout.type_code:02X}), {layout.size} bytes:",
            "",
            "| offset | field | type | what |",
            "|---|---|---|---|",
        ]
        rows += [
            f"| {at} | {f.name} | {f.wire_type()} | {_md(f.what)} |"
            for f, at in zip(layout.fields, layout.offsets(), strict=True)
        ]
        parts.append("\n".join(rows))
    return "\n\n".join(parts) + "\n"


BEGIN = "<!-- generated by `python -m hardware.firmware.wire --write-docs`: do not edit -->"
END = "<!-- end of the generated part -->"
_PART = re.compile(re.escape(BEGIN) + r"\n.*?" + re.escape(END), re.DOTALL)


def with_tables(markdown: str) -> str:
    """`markdown` with the part between BEGIN and END regenerated; ValueError without them."""
    if len(_PART.findall(markdown)) != 1:
        raise ValueError(f"PROTOCOL.md must hold one generated part: {BEGIN!r} ... {END!r}")
    return _PART.sub(lambda _: f"{BEGIN}\n\n{protocol_tables()}\n{END}", markdown)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m hardware.firmware.wire", description="PROTOCOL.md's payload tables."
    )
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write-docs", action="store_true", help="regenerate PROTOCOL.md's part")
    group.add_argument("--check", action="store_true", help="exit 1 if that part is stale")
    args = parser.parse_args(argv)
    text = PROTOCOL_MD.read_text(encoding="utf-8")
    new = with_tables(text)
    if args.check:
        if new != text:
            print(f"{PROTOCOL_MD} is stale: run python -m hardware.firmware.wire --write-docs")
            return 1
        return 0
    if new != text:
        PROTOCOL_MD.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
