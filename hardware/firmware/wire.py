"""PROTOCOL.md's fixed layouts, declared once (docs/DESIGN.md §5; decisions 0063, 0065): each
message's ordered fields (name, C type, count, meaning, the firmware's source). From them
(hardware/firmware/wire_gen.py): `artro_wire.h`, the host's app/firmware/wire_messages.py and
PROTOCOL.md's tables (`python -m hardware.firmware.wire --write-docs --write-python`; `--check`
exits 1 when one is stale)."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from pathlib import Path

from hardware.firmware import wire_gen
from hardware.firmware.wire_model import Bare, Field, Layout, Message

WIRE_HEADER_NAME = "artro_wire.h"
PROTOCOL_MD = Path(__file__).resolve().parent / "PROTOCOL.md"
WIRE_MESSAGES = Path(__file__).resolve().parents[2] / "app" / "firmware" / "wire_messages.py"

_LAW_SWITCHES = (
    "(SWITCH(TILT_ENABLED) | SWITCH(YAW_RATE_ENABLED) << 1 | SWITCH(DAMPING_ENABLED) << 2"
    " | SWITCH(COP_ENABLED) << 3 | SWITCH(TIMING_ENABLED) << 4)"
)

# fmt: off
# ---- host -> robot: the firmware copies each field out with wire_unpack_<msg>(p, &field, ...)
SET_MOTION = Layout("SET_MOTION", 0x02, "the motion vector (parameter ids 0..3)", (
    Field("values", "float", 4, "a_r, a_p, a_y, ca"),
), sender="host", answer="ACK")
SET_PARAM = Layout("SET_PARAM", 0x03, "one parameter's value", (
    Field("id", "uint8_t", 1, "parameter id"),
    Field("value", "float", 1, "its value"),
), sender="host", answer="ACK")
SET_PARAMS = Layout("SET_PARAMS", 0x04, "consecutive parameters' values", (
    Field("first", "uint8_t", 1, "the first one's id"),
    Field("count", "uint8_t", 1, "how many: 1..48"),
), sender="host", answer="ACK",
    repeated=Field("values", "float", 48, "their values, from id first"), count_field="count")
GET_PARAM = Layout("GET_PARAM", 0x05, "asks for one parameter's value", (
    Field("id", "uint8_t", 1, "parameter id"),
), sender="host", answer="PARAM")
GET_PARAMS = Layout("GET_PARAMS", 0x06, "asks for consecutive parameters' values", (
    Field("first", "uint8_t", 1, "the first one's id"),
    Field("count", "uint8_t", 1, "how many: 1..48"),
), sender="host", answer="PARAMS")
TELEMETRY_ON = Layout("TELEMETRY_ON", 0x0A, "what the robot streams", (
    Field("mode", "uint8_t", 1, "0 nothing, 1 one TELEMETRY per frame, 2 one SENSORS per frame"),
), sender="host", answer="ACK")

# ---- robot -> host: the firmware packs each with wire_pack_<msg>(p, params)
ACK = Layout("ACK", 0x81, "a request taken", (
    Field("acked", "uint8_t", 1, "the type of the request", "type"),
    Field("effective_frame", "uint32_t", 1, "the first frame it reaches (Effective frame)",
          "control_effective_frame()"),
), includes=("control.h",), params="uint8_t type")
NAK = Layout("NAK", 0x82, "a request refused, which changed nothing", (
    Field("rejected", "uint8_t", 1, "the type of the request, 0 if not known", "type"),
    Field("reason", "uint8_t", 1, "why: the NAK reasons below", "reason", host="NakReason"),
    Field("detail", "uint8_t", 1, "the NAK reasons' detail", "detail"),
), params="uint8_t type, uint8_t reason, uint8_t detail")
INFO = Layout("INFO", 0x83, "the firmware's protocol, its parameters and where it is", (
    Field("version", "uint8_t", 1, "protocol version (2)", "PROTO_VERSION"),
    Field("param_count", "uint8_t", 1, "parameter count", "ARTRO_PARAM_COUNT"),
    Field("schema_hash", "uint32_t", 1, "schema hash (Parameter ids)", "ARTRO_SCHEMA_HASH"),
    Field("frame", "uint32_t", 1, "the frame it is on", "control_frame()"),
    Field("state", "uint8_t", 1, "state: the states below", "control_state()", host="RunState"),
), includes=("artro_schema.h", "control.h", "protocol.h"))
PARAM = Layout("PARAM", 0x84, "one parameter's value", (
    Field("id", "uint8_t", 1, "parameter id", "id"),
    Field("value", "float", 1, "its value", "g_params[id]"),
), includes=("params.h",), params="uint8_t id")
PARAMS = Layout("PARAMS", 0x85, "consecutive parameters' values", (
    Field("first", "uint8_t", 1, "the first one's id", "first"),
    Field("count", "uint8_t", 1, "how many: 1..48", "count"),
), includes=("params.h",), params="uint8_t first, uint8_t count",
    repeated=Field("values", "float", 48, "their values, from id first", "&g_params[first]"),
    count_field="count")
TELEMETRY = Layout("TELEMETRY", 0x86, "the plan sent last, the clock's phase, flags", (
    Field("frame", "uint32_t", 1, "the frame of the plan sent last", "plan->frame"),
    Field("phase_rad", "float", 1, "the walking clock's phase φ_Trunk (rad)", "phase"),
    Field("ocr", "uint16_t", 12, "OCR of each servo's pulse, in the gait's joint order",
          "plan->servo_ocr"),
    Field("saturated", "uint16_t", 1, "bit i: servo i clipped", "plan->saturated"),
    Field("flags", "uint8_t", 1, "flags: the TELEMETRY flags below", "flags"),
    Field("state", "uint8_t", 1, "state: the states below", "plan->state", host="RunState"),
), includes=("plan.h",), params="const plan_t *plan, float phase, uint8_t flags")
ANGLES = Layout("ANGLES", 0x87, "the joint angles of the plan sent last", (
    Field("frame", "uint32_t", 1, "the frame of the plan sent last", "plan->frame"),
    Field("angles_rad", "float", 12, "joint angles (rad), in the gait's joint order",
          "plan->angle"),
), includes=("plan.h",), params="const plan_t *plan")
SENSORS = Layout(
    "SENSORS", 0x88, "the balance sensors and laws of the frame the firmware planned last", (
        Field("frame", "uint32_t", 1, "the frame the laws corrected", "g_law_frame",
              dashboard="value"),
        Field("status", "uint8_t", 1, "status: the SENSORS status bits below", "g_sensor_status",
              dashboard="bits"),
        Field("imu_failures", "uint8_t", 1, "IMU failures since boot, 255 at most",
              "g_imu_failures", dashboard="value"),
        Field("laws", "uint8_t", 1,
              "laws on: bit 0 tilt, 1 yaw rate, 2 damping, 3 CoP, 4 step timing", _LAW_SWITCHES,
              dashboard="bits"),
        Field("support", "int8_t", 1, "support foot: 0 left, 1 right, −1 none",
              "g_law_output.support", dashboard="value"),
        Field("gyro_offset", "int16_t", 3, "gyro offsets x, y, z (the boot calibration, counts)",
              "g_gyro_offset"),
        Field("accel_raw", "int16_t", 3, "accelerometer x, y, z (raw counts)",
              "g_sensor_raw.accel"),
        Field("gyro_raw", "int16_t", 3, "gyro x, y, z (raw counts, before the offset)",
              "g_sensor_raw.gyro"),
        Field("adc", "uint16_t", 8, "ADC: left foot front-left, front-right, back-left, "
              "back-right, then the right foot's", "g_sensor_raw.adc"),
        Field("attitude_rad", "float", 2, "attitude estimate pitch, roll (rad)",
              "g_law_output.attitude", dashboard="float32"),
        Field("tilt_rad", "float", 2, "tilt trim pitch, roll (rad)", "g_law_output.tilt",
              dashboard="float32"),
        Field("a_y_delta", "float", 1, "the yaw-rate loop's change of a_y",
              "g_law_output.a_y_delta", dashboard="float32"),
        Field("cop_rad", "float", 2, "CoP correction: the support foot's ankle pitch, roll (rad)",
              "g_law_output.cop", dashboard="float32"),
    ),
    includes=("laws.h", "params.h", "sensors.h"),
)
# fmt: on

#: every message of PROTOCOL.md, in its order: the host's, then the robot's
MESSAGES: tuple[Message, ...] = (
    Bare("PING", 0x01, answer="INFO"),
    SET_MOTION, SET_PARAM, SET_PARAMS, GET_PARAM, GET_PARAMS,
    Bare("START", 0x07, "walk, torque on; the balance laws start anew", "ACK"),
    Bare("STOP", 0x08, "walking clock stopped, pose held; the balance laws rest", "ACK"),
    Bare("TORQUE_OFF", 0x09, "no pulses: every line low; the balance laws rest", "ACK"),
    TELEMETRY_ON,
    Bare("GET_TELEMETRY", 0x0B, answer="TELEMETRY"),
    Bare("GET_ANGLES", 0x0C, answer="ANGLES"),
    Bare("RESET_PARAMS", 0x0D, "back to the compiled-in set", "ACK"),
    Bare("GET_SENSORS", 0x0E, answer="SENSORS"),
    ACK, NAK, INFO, PARAM, PARAMS, TELEMETRY, ANGLES, SENSORS,
)  # fmt: skip
#: the messages with a payload
LAYOUTS: tuple[Layout, ...] = tuple(m for m in MESSAGES if isinstance(m, Layout))


def c_wire_header(layouts: Sequence[Layout] = LAYOUTS) -> str:
    """The firmware's `artro_wire.h` (wire_gen.c_wire_header)."""
    return wire_gen.c_wire_header(MESSAGES, layouts, WIRE_HEADER_NAME)


def python_module(layouts: Sequence[Layout] = LAYOUTS) -> str:
    """The host's app/firmware/wire_messages.py (wire_gen.python_module)."""
    return wire_gen.python_module(MESSAGES, layouts)


BEGIN = "<!-- generated by `python -m hardware.firmware.wire --write-docs`: do not edit -->"
END = "<!-- end of the generated part -->"
_PART = re.compile(re.escape(BEGIN) + r"\n.*?" + re.escape(END), re.DOTALL)


def with_tables(markdown: str) -> str:
    """`markdown` with the part between BEGIN and END regenerated; ValueError without them."""
    if len(_PART.findall(markdown)) != 1:
        raise ValueError(f"PROTOCOL.md must hold one generated part: {BEGIN!r} ... {END!r}")
    tables = wire_gen.protocol_tables(MESSAGES)
    return _PART.sub(lambda _: f"{BEGIN}\n\n{tables}\n{END}", markdown)


def _generated() -> dict[Path, str]:
    """{file: the text it must hold}: PROTOCOL.md and app/firmware/wire_messages.py."""
    return {
        PROTOCOL_MD: with_tables(PROTOCOL_MD.read_text(encoding="utf-8")),
        WIRE_MESSAGES: python_module(),
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m hardware.firmware.wire",
        description="PROTOCOL.md's payload tables and the host's app/firmware/wire_messages.py.",
    )
    parser.add_argument("--write-docs", action="store_true", help="regenerate PROTOCOL.md's part")
    parser.add_argument(
        "--write-python", action="store_true", help="regenerate app/firmware/wire_messages.py"
    )
    parser.add_argument("--check", action="store_true", help="exit 1 if either is stale")
    args = parser.parse_args(argv)
    if args.check == (args.write_docs or args.write_python):
        parser.error("give --check, or --write-docs and/or --write-python")
    wanted = {PROTOCOL_MD: args.write_docs, WIRE_MESSAGES: args.write_python}
    stale = 0
    for path, text in _generated().items():
        old = path.read_text(encoding="utf-8") if path.exists() else ""
        if text == old:
            continue
        if args.check:
            flag = "--write-docs" if path == PROTOCOL_MD else "--write-python"
            print(f"{path} is stale: run python -m hardware.firmware.wire {flag}")
            stale = 1
        elif wanted[path]:
            path.write_text(text, encoding="utf-8")
    return stale


if __name__ == "__main__":
    sys.exit(main())
