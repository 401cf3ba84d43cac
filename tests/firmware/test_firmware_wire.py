"""The wire layouts declared once (hardware/firmware/wire.py; decisions 0063 and 0065): the C
header, the host's messages (app/firmware/wire_messages.py) and PROTOCOL.md's tables come from
the declaration, and the bytes the firmware sends are the ones its hand-written packing sent."""

from __future__ import annotations

import dataclasses
import re
import struct

import pytest

from app.firmware import protocol as proto
from app.firmware.build import build_firmware
from app.firmware.emulator import Mcu
from app.firmware.sensor_feed import RawSample, at_rest, sample_of
from gait.params import LAW_GROUPS
from hardware.firmware import wire
from hardware.firmware.schema import complete_document, param_specs
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


def test_check_finds_a_stale_host_module_and_write_python_renews_it(tmp_path, monkeypatch) -> None:
    """wire_messages.py as another commit left it: `--check` exits 1, `--write-python` renews it
    (here a copy in tmp_path: the checkout's file stays as it is)."""
    copy = tmp_path / "wire_messages.py"
    copy.write_text(wire.python_module().replace("    frame: int", "    frame: float", 1))
    monkeypatch.setattr(wire, "WIRE_MESSAGES", copy)
    assert wire.main(["--check"]) == 1
    assert wire.main(["--write-python"]) == 0
    assert copy.read_text(encoding="utf-8") == wire.python_module()
    assert wire.main(["--check"]) == 0
    with pytest.raises(SystemExit):  # neither a check nor a write
        wire.main([])


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


#: each request and the payload of the firmware's answer (from frame 6, 4 frames apart, at rest),
#: as the hand-written send_ack/nak/info/angles/params and dispatch() packed and read them; None:
#: not compared (the schema's whole set)
HAND_PACKED_ANSWERS = (
    (proto.encode(proto.Msg.PING), None),
    (proto.set_motion(0.01, 0.02, 0.03, 0.1), "020b000000"),
    (proto.set_param(5, 0.3), "030505"),
    (proto.set_params([0.01, 0.02], 0), "0413000000"),
    (proto.get_param(7), "070ad7a33d"),
    (proto.get_params(3, 5), "0305cdcccc3d1ae02e3f0000803f32cb5e3e0ad7a33d"),
    (proto.get_params(0, 48), None),
    (proto.command(proto.Msg.GET_ANGLES), "2200000065bf903c3b589e3dce934cbc00000000157b89bc66ea3d"
     "bd6a7f113d42f04d3e8525a23d94e4e6bdeaf9563cc7c65fbe"),
    (proto.command(proto.Msg.GET_TELEMETRY), "26000000ef78d83fd30b690ca70bb70ba50bfd0ada0b440c21"
     "0c080be30b410b00000000"),
    (proto.telemetry_on(0), "0a2b000000"),
    (proto.telemetry_on(3), "0a0503"),
    (proto.get_param(250), "0504fa"),
    (proto.get_params(0, 0), "060500"),
    (proto.encode(proto.Msg.SET_PARAM, b"\x01"), "030301"),
    (proto.encode(0x55), "550200"),
    (proto.set_param(0, 1e9), "030500"),
    (proto.command(proto.Msg.STOP), "0847000000"),
    # the parameter count, the schema hash aside
    (proto.encode(proto.Msg.PING), f"02{len(param_specs()):02x}........4a00000001"),
    (proto.set_params([1.0] * 3, 200), "0404c8"),
    (proto.encode(proto.Msg.SET_PARAMS, bytes(6)), "040306"),
)  # fmt: skip


@pytest.mark.slow
def test_every_generated_packing_and_unpacking_sends_the_hand_packed_bytes() -> None:
    """ACK, NAK, INFO, PARAM(S), ANGLES out and the requests in: the bytes of the hand-written
    C (recorded before the packing was generated), one answer each."""
    doc = complete_document(preset("tuned", a_p=0.05, a_y=0.05))
    with Mcu(build_firmware(doc).elf, sensors=sample_of(at_rest())) as mcu:
        mcu.run_to_frame(5)
        mcu.take_uart()
        frame = 6
        for request, payload in HAND_PACKED_ANSWERS:
            mcu.send(request)
            frame += 4
            mcu.run_to_frame(frame)
            (answer,) = proto.Decoder().feed(mcu.take_uart()[1])
            if payload is not None:
                sent = answer.payload.hex()
                assert re.fullmatch(payload, sent), (proto.type_name(request[2]), sent)
    assert len(answer.payload) == wire.NAK.size  # the last: a NAK


def test_the_host_classes_and_message_types_are_the_declarations() -> None:
    """protocol.Msg is the declared messages; each request has its answer; the generated module
    is fresh; a repeated field unpacks as its count says; a state or reason not known is said."""
    assert [(m.name, m.value) for m in proto.Msg] == [(m.name, m.type_code) for m in wire.MESSAGES]
    assert set(proto.ACKED) | set(proto.DATA_REPLIES) == {m for m in proto.Msg if m < 0x80}
    for m in (m for m in wire.MESSAGES if m.type_code < 0x80):  # PROTOCOL.md's answer is the host's
        request = proto.Msg[m.name]
        answer = "ACK" if request in proto.ACKED else proto.DATA_REPLIES[request][0].name
        assert answer == m.answer, m.name
    assert wire.python_module() == wire.WIRE_MESSAGES.read_text(encoding="utf-8")
    assert [f.name for f in dataclasses.fields(proto.Params)] == ["first", "values"]
    params = proto.parse(proto.Message(proto.Msg.PARAMS, bytes([3, 2]) + bytes(8)))
    assert params == proto.Params(3, (0.0, 0.0))
    assert wire.PARAMS.unpack(bytes([3, 1]) + bytes(4)) == {
        "first": 3,
        "count": 1,
        "values": (0.0,),
    }
    with pytest.raises(struct.error):
        wire.PARAMS.unpack(bytes([3, 2]) + bytes(4))
    with pytest.raises(proto.LinkError, match="names state 7"):
        proto.parse(proto.Message(proto.Msg.INFO, bytes(10) + b"\x07"))
    nak = proto.parse(proto.Message(proto.Msg.NAK, bytes([3, 9, 0])))
    assert isinstance(nak, proto.Nak) and nak.reason == 9


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
    # a macro is not a variable: no size check of PROTO_VERSION (2u, an unsigned int)
    assert "sizeof(PROTO_VERSION)" not in header and "(uint8_t)(PROTO_VERSION)" in header
    assert "static inline uint8_t wire_pack_params(uint8_t *p, uint8_t first, uint8_t count)" in (
        header
    )
    assert (
        "memcpy(values, &p[ARTRO_WIRE_SET_PARAMS_VALUES], 4u * p[ARTRO_WIRE_SET_PARAMS_COUNT]);"
        in (header)
    )
