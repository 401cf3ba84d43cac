"""The wire layouts declared once (hardware/firmware/wire.py; the decision record:
docs/decisions/0063-wire-layouts-declared-once.md): the C header, the host's decoder and
PROTOCOL.md's tables come from the declaration, and the SENSORS bytes the firmware sends are the
ones its hand-written packing sent."""

from __future__ import annotations

import dataclasses

import pytest

from app.firmware import protocol as proto
from app.firmware.build import build_firmware
from app.firmware.emulator import Mcu
from app.firmware.sensor_feed import RawSample, at_rest, sample_of
from gait.params import LAW_GROUPS
from hardware.firmware import wire
from hardware.firmware.schema import complete_document
from hardware.firmware.wire import (
    BEGIN,
    PROTOCOL_MD,
    SENSORS,
    TELEMETRY,
    c_wire_header,
    with_tables,
)
from tests.testing.firmware_support import preset

#: the SENSORS payload of `walk_replies()` as the hand-written send_sensors() packed it
#: (recorded at commit 4d6ecab, before the packing was generated)
HAND_PACKED = (
    "0c00000001000f00c50097ff34007cfcbc02e43e9001d4fe7800f4016202a4017c011e0000000c0005006b97513d"
    "90af453d90ac5e3a4aa6263a2cc9393b4a33973b0bb57fba"
)
#: the TELEMETRY payload after it, as the hand-written send_telemetry() packed it
HAND_PACKED_TELEMETRY = "0e000000312b8abea80b530bcb0bab0ba10b950c820b3b0d900da107bd0db70900000000"


def walk_replies() -> dict[int, bytes]:
    """{type: payload} of the SENSORS and TELEMETRY the firmware sends at frame 12 of a walk
    with every law on, leaning and loaded on one foot (every field nonzero)."""
    doc = complete_document(preset("tuned", a_p=0.05, a_y=0.05))
    for law in LAW_GROUPS:
        doc["gait"][law]["enabled"] = True
    raw = RawSample(
        accel=(-900, 700, 16100), gyro=(400, -300, 120), adc=(500, 610, 420, 380, 30, 0, 12, 5)
    )
    build = build_firmware(doc)
    with Mcu(build.elf, sensors=sample_of(at_rest())) as mcu:
        mcu.set_sensors(sample_of(raw))
        mcu.run_to_frame(12)
        mcu.take_uart()
        replies = {}
        for request, until in ((proto.Msg.GET_SENSORS, 14), (proto.Msg.GET_TELEMETRY, 16)):
            mcu.send(proto.command(request))
            mcu.run_to_frame(until)
            _, data = mcu.take_uart()
            replies.update({m.type: m.payload for m in proto.Decoder().feed(data)})
    return replies


def test_the_payload_bytes_are_the_hand_packed_ones() -> None:
    replies = walk_replies()
    sent = replies[proto.Msg.SENSORS]
    # the one change since: the laws byte (offset 6) sets bit 4, step timing, as PROTOCOL.md said
    hand = bytearray.fromhex(HAND_PACKED)
    assert hand[SENSORS.offsets()[SENSORS.names.index("laws")]] == 0x0F
    hand[6] |= 0x10
    assert sent == bytes(hand)
    assert replies[proto.Msg.TELEMETRY].hex() == HAND_PACKED_TELEMETRY


def test_protocol_md_holds_the_generated_tables() -> None:
    """PROTOCOL.md's tables are the declaration's; a stale copy is found (`--check` exits 1)."""
    text = PROTOCOL_MD.read_text(encoding="utf-8")
    assert with_tables(text) == text, "run: python -m hardware.firmware.wire --write-docs"
    stale = text.replace("| 4 | status | u8 |", "| 4 | status | u16 |")
    assert stale != text and with_tables(stale) == text
    with pytest.raises(ValueError, match="one generated part"):
        with_tables(text.replace(BEGIN, ""))
    assert wire.main(["--check"]) == 0


def test_the_host_decodes_the_declared_fields() -> None:
    """protocol.Sensors has the declaration's fields, in order; the struct is the declaration's."""
    assert tuple(f.name for f in dataclasses.fields(proto.Sensors)) == SENSORS.names
    assert tuple(f.name for f in dataclasses.fields(proto.Telemetry)) == TELEMETRY.names
    assert proto.PAYLOAD_BYTES[proto.Msg.TELEMETRY] == TELEMETRY.size == 36
    telemetry = proto.parse(
        proto.Message(proto.Msg.TELEMETRY, bytes.fromhex(HAND_PACKED_TELEMETRY))
    )
    assert isinstance(telemetry, proto.Telemetry) and telemetry.state == proto.RunState.WALK
    assert telemetry.frame == 14 and len(telemetry.ocr) == 12 and 0 < abs(telemetry.phase_rad) < 3.2
    assert proto.PAYLOAD_BYTES[proto.Msg.SENSORS] == SENSORS.size == 70
    decoded = proto.parse(proto.Message(proto.Msg.SENSORS, bytes.fromhex(HAND_PACKED)))
    assert isinstance(decoded, proto.Sensors)
    assert (decoded.frame, decoded.laws, decoded.support) == (12, 0x0F, 0)
    assert [law for law, bit in proto.LAW_BITS.items() if 0x1F & bit] == list(LAW_GROUPS)
    assert decoded.adc == (500, 610, 420, 380, 30, 0, 12, 5)
    assert decoded.cop_rad[1] < 0 < decoded.cop_rad[0]


def test_the_c_header_gives_each_field_its_offset_and_checks_its_source() -> None:
    header = c_wire_header()
    header.encode("ascii")  # the build writes it as ASCII
    assert "#define ARTRO_WIRE_SENSORS_BYTES 70u" in header
    assert "#define ARTRO_WIRE_SENSORS_COP_RAD               62u /* 2 x f32 */" in header
    assert '_Static_assert(sizeof(g_sensor_raw.adc) == 16, "' in header
    assert "static inline void wire_pack_sensors(uint8_t *p)" in header
    assert (
        "wire_pack_telemetry(uint8_t *p, const plan_t *plan, float phase, uint8_t flags)" in header
    )
    assert "_Static_assert(sizeof(plan->servo_ocr) == 24, " in header
