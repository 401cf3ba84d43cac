"""The bus servos' pure model (hardware/servo_bus.py): packets against the e-Manual's and
hand-computed bytes, the stream parser, the servos' answers and the bus's timing in µs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hardware.servo_bus import (
    BROADCAST_ID,
    ERR_ACCESS,
    ERR_CRC,
    ERR_INSTRUCTION,
    PING,
    READ,
    STS3215,
    SYNC_READ,
    WRITE,
    XM430_W350,
    BusServo,
    Malformed,
    Packet,
    Parser,
    Present,
    ServoBus,
    angle_to_steps,
    answers_done_us,
    bus_frame,
    crc16,
    dxl_packet,
    dxl_status,
    dxl_sync_read,
    dxl_sync_write,
    steps_to_angle,
    sts_packet,
    sts_sync_read,
    sts_sync_write,
    wire_us,
)

H = bytes.fromhex


def test_dynamixel_packets_are_the_e_manuals_examples() -> None:
    # Protocol 2.0's examples: PING ID 1 and its status (model 1030, firmware 0x26); READ of
    # the present position; WRITE goal 512; SYNC_WRITE 150 and 170; SYNC_READ of IDs 1, 2
    assert dxl_packet(1, PING) == H("ffff fd00 0103 0001 194e")
    assert dxl_status(1, 0, H("060426")) == H("ffff fd00 0107 0055 0006 0426 655d")
    assert dxl_packet(1, READ, H("84000400")) == H("ffff fd00 0107 0002 8400 0400 1d15")
    assert dxl_packet(1, WRITE, H("740000020000")) == H("ffff fd00 0109 0003 7400 0002 0000 ca89")
    assert dxl_sync_write(116, 4, {1: 150, 2: 170}) == H(
        "ffff fd00 fe11 0083 7400 0400 0196 0000 0002 aa00 0000 8287"
    )
    assert dxl_packet(BROADCAST_ID, SYNC_READ, H("840004000102")) == H(
        "ffff fd00 fe09 0082 8400 0400 0102 cefa"
    )
    assert dxl_sync_read(132, 4, [1, 2]) == H("ffff fd00 fe09 0082 8400 0400 0102 cefa")
    assert crc16(H("fffffd0001030001")) == 0x4E19


def test_byte_stuffing_adds_fd_after_ff_ff_fd_and_the_parser_takes_it_out() -> None:
    packet = dxl_packet(1, WRITE, H("7400fffffd00"))
    # instruction 03, params 74 00 FF FF FD [FD] 00: length 8 + 2 = 10
    assert packet[:7] == H("fffffd00010a00")
    assert packet[7:-2] == H("037400fffffdfd00")
    assert crc16(packet[:-2]) == int.from_bytes(packet[-2:], "little")
    (found,) = Parser("dynamixel").feed(packet)
    assert found == Packet(1, WRITE, H("7400fffffd00"), len(packet))


def test_feetech_packets_carry_the_inverted_sum() -> None:
    # PING ID 1: FF FF 01 02 01, checksum ~(1 + 2 + 1) = 0xFB
    assert sts_packet(1, PING) == H("ffff010201fb")
    # READ 2 bytes at 56 from ID 3: ~(3 + 4 + 2 + 56 + 2) = ~0x43 = 0xBC
    assert sts_packet(3, READ, bytes([56, 2])) == H("ffff0304023802bc")
    # SYNC_WRITE goal (42, 2 bytes) 2048 to ID 1, 1000 to ID 2
    body = H("fe0a832a02") + H("010008") + H("02e803")
    assert sts_sync_write(42, 2, {1: 2048, 2: 1000}) == H("ffff") + body + bytes(
        [~sum(body) & 0xFF]
    )
    # SYNC_READ of the present position (56, 2 bytes) from IDs 1, 2: ~(FE+06+82+38+02+01+02)
    assert sts_sync_read(56, 2, [1, 2]) == H("ffff fe06 8238 0201 023c")


def test_the_parser_splits_skips_noise_and_names_a_bad_crc() -> None:
    parser = Parser("dynamixel")
    ping = dxl_packet(1, PING)
    bad = bytearray(dxl_packet(2, READ, H("84000400")))
    bad[-1] ^= 0xFF
    stream = H("001122") + ping + bytes(bad) + ping
    found = []
    for i in range(0, len(stream), 3):  # arriving in pieces
        found += parser.feed(stream[i : i + 3])
    assert found == [
        Malformed(None, "noise", 3),
        Packet(1, PING, b"", 10),
        Malformed(2, "crc", 14),
        Packet(1, PING, b"", 10),
    ]
    assert Parser("feetech").feed(H("ffff0102") + b"\x01\x00") == [Malformed(1, "checksum", 6)]
    with pytest.raises(ValueError, match="dynamixel"):
        Parser("modbus")


def test_angles_are_4096_steps_a_turn_2048_at_zero() -> None:
    assert angle_to_steps([0.0, math.pi / 2, -math.pi / 2, 10.0, -10.0]).tolist() == [
        2048,
        3072,
        1024,
        4095,
        0,
    ]
    assert steps_to_angle(3072) == pytest.approx(math.pi / 2, abs=0)
    step = 2 * math.pi / 4096
    assert angle_to_steps(0.5 * step).tolist() == 2048  # half a step: to even
    assert angle_to_steps(1.5 * step).tolist() == 2050


def test_timing_is_whole_microseconds_at_ten_bits_a_byte() -> None:
    assert wire_us(10, 1_000_000) == 100
    assert wire_us(1, 57_600) == 174  # 173.6 rounded up
    assert wire_us(0, 9600) == 0
    with pytest.raises(ValueError, match="baud must be > 0"):
        wire_us(1, 0)
    # two answers of 15 bytes after 500 µs each, from an instruction ending at 1000 µs
    assert answers_done_us(1000, [15, 15], [500, 500], 1_000_000) == [1650, 2300]


def test_a_sync_write_per_frame_takes_effect_when_its_last_byte_arrives() -> None:
    frame = bus_frame(3, np.zeros(12))
    # 7 bytes of head, the instruction, 4 of address and size, 12 × (ID + 4 bytes), the CRC
    assert len(frame.packet) == 7 + 1 + 4 + 12 * 5 + 2
    assert (frame.start_us, frame.wire_us, frame.effect_us) == (60_000, 740, 60_740)
    assert frame.goal_steps == (2048,) * 12
    assert frame.substep() == 1  # 740 µs in: the step starting at 1 ms
    assert frame.substep(500) == 2 and frame.substep(740) == 1 and frame.substep(250) == 3
    sts = bus_frame(0, np.full(12, 0.1), protocol="feetech")
    assert len(sts.packet) == 4 + 3 + 12 * 3 + 1  # FF FF ID LEN, INST A S, 12 × 3, CHK
    assert sts.effect_us == wire_us(len(sts.packet), 1_000_000)
    assert sts.goal_steps == (2048 + 65,) * 12  # 0.1 rad = 65.19 steps
    assert sts.goal_rad[0] == pytest.approx(65 * 2 * math.pi / 4096, abs=0)


def _dxl_bus() -> ServoBus:
    return ServoBus(BusServo("dynamixel", i, 1_000_000) for i in (1, 2, 3))


def test_an_xm430_answers_ping_read_write_and_errors_as_the_e_manual_says() -> None:
    bus = _dxl_bus()
    (ping,) = bus.handle(Packet(2, PING, b"", 10))
    assert ping.data == dxl_status(2, 0, (1020).to_bytes(2, "little") + bytes([52]))
    assert ping.return_delay_us == 500  # 250 × 2 µs, the factory value
    servo = bus.by_id(2)
    assert servo is not None
    servo.show(Present(math.pi / 2, -1.0, 0.25, 11.1, 30.0))
    (read,) = bus.handle(Packet(2, READ, H("84000400"), 14))
    assert read.data == dxl_status(2, 0, (3072).to_bytes(4, "little"))
    (velocity,) = bus.handle(Packet(2, READ, H("7e000600"), 14))  # load, velocity
    # -1 rad/s = -41.7 units of 0.229 rev/min; load 25 % = 250 units of 0.1 %
    assert velocity.data == dxl_status(
        2, 0, (250).to_bytes(2, "little") + (-42).to_bytes(4, "little", signed=True)
    )
    (write,) = bus.handle(Packet(2, WRITE, H("4000") + b"\x01", 13))  # torque on
    assert write.data == dxl_status(2, 0) and servo.torque_on
    (locked,) = bus.handle(Packet(2, WRITE, H("0900") + b"\x00", 13))  # EEPROM, torque on
    assert locked.data == dxl_status(2, ERR_ACCESS)
    (unknown,) = bus.handle(Packet(2, 0x10, b"", 10))
    assert unknown.data == dxl_status(2, ERR_INSTRUCTION)
    assert bus.handle(Packet(9, PING, b"", 10)) == [] and bus.unanswered == 1


def test_sync_write_and_sync_read_answer_in_the_order_asked() -> None:
    bus = _dxl_bus()
    write = Parser("dynamixel").feed(dxl_sync_write(116, 4, {1: 1000, 3: 3000}))[0]
    assert isinstance(write, Packet)
    assert bus.handle(write) == []
    assert [s.get("goal_position") for s in bus.servos] == [1000, 2048, 3000]
    read = Packet(BROADCAST_ID, SYNC_READ, H("74000400") + bytes([3, 1]), 0)
    answers = bus.handle(read)
    assert [a.servo_id for a in answers] == [3, 1]
    assert answers[0].data == dxl_status(3, 0, (3000).to_bytes(4, "little"))


def test_a_bad_crc_gets_the_crc_error_from_its_servo_and_noise_silence() -> None:
    bus = _dxl_bus()
    (answer,) = bus.handle(Malformed(3, "crc", 14))
    assert answer.data == dxl_status(3, ERR_CRC)
    assert bus.handle(Malformed(None, "noise", 5)) == []
    assert bus.handle(Malformed(BROADCAST_ID, "crc", 5)) == []
    assert bus.malformed == {"crc": 2, "noise": 1}


def test_an_sts3215_answers_and_stays_silent_on_a_bad_checksum() -> None:
    bus = ServoBus(BusServo("feetech", i, 1_000_000) for i in (1, 2))
    (ping,) = bus.handle(Packet(1, PING, b"", 6))
    assert ping.data == H("ffff010200fc")  # ~(1 + 2 + 0) = 0xFC
    (model,) = bus.handle(Packet(1, READ, bytes([3, 2]), 8))
    assert model.data == sts_packet(1, 0, (777).to_bytes(2, "little"))
    servo = bus.servos[1]
    servo.show(Present(-0.1, -2.0, -0.5, 7.4))
    (speed,) = bus.handle(Packet(2, READ, bytes([56, 8]), 8))
    # position 2048 - 65, speed 1304 steps/s (2 rad/s) with bit 15, load 500 with bit 10, 74 × 0.1 V
    assert speed.data == sts_packet(
        2,
        0,
        H("bf07")
        + (1304 | 1 << 15).to_bytes(2, "little")
        + (500 | 1 << 10).to_bytes(2, "little")
        + bytes([74, 25]),
    )
    assert bus.handle(Malformed(2, "checksum", 8)) == []
    assert bus.handle(Packet(2, 0x10, b"", 6)) == []
    assert STS3215.fields["goal_position"] == (42, 2)
    assert XM430_W350.fields["goal_position"] == (116, 4)


def test_a_servo_refuses_what_it_cannot_be() -> None:
    with pytest.raises(ValueError, match="dynamixel"):
        BusServo("pwm", 1, 1_000_000)
    with pytest.raises(ValueError, match=r"XM430-W350 runs at \[9600"):
        BusServo("dynamixel", 1, 12345)
    with pytest.raises(ValueError, match="one protocol"):
        ServoBus([BusServo("dynamixel", 1, 1_000_000), BusServo("feetech", 2, 1_000_000)])


def _valid_packets(protocol: str) -> list[bytes]:
    if protocol == "dynamixel":
        return [
            dxl_packet(1, PING),
            dxl_packet(2, READ, H("84000400")),
            dxl_packet(3, WRITE, H("7400") + (1000).to_bytes(4, "little")),
            dxl_sync_write(116, 4, {1: 100, 2: 200}),
            dxl_packet(BROADCAST_ID, SYNC_READ, H("840004000102")),
        ]
    return [
        sts_packet(1, PING),
        sts_packet(2, READ, bytes([56, 2])),
        sts_sync_write(42, 2, {1: 100, 2: 200}),
        sts_packet(BROADCAST_ID, SYNC_READ, bytes([56, 2, 1, 2])),
    ]


@settings(max_examples=300, deadline=None)
@given(
    protocol=st.sampled_from(["dynamixel", "feetech"]),
    noise=st.lists(st.binary(max_size=40), max_size=6),
    flips=st.lists(st.tuples(st.integers(0, 400), st.integers(1, 255)), max_size=4),
    cut=st.integers(0, 64),
)
def test_no_stream_of_bytes_breaks_the_parser_or_a_servo(
    protocol: str, noise: list[bytes], flips: list[tuple[int, int]], cut: int
) -> None:
    """Valid packets among random bytes, with bytes flipped and pieces cut: every item is
    handled, every answer is a whole packet, and the parser keeps no more than one packet's
    worth; a valid packet after the mess is answered."""
    valid = _valid_packets(protocol)
    stream = bytearray()
    for i, chunk in enumerate(noise):
        stream += chunk + valid[i % len(valid)]
    for at, mask in flips:
        if stream:
            stream[at % len(stream)] ^= mask
    stream = stream[cut:]
    bus = ServoBus(BusServo(protocol, i, 1_000_000) for i in (1, 2, 3))
    parser = Parser(protocol)
    for item in parser.feed(bytes(stream)):
        for answer in bus.handle(item):
            assert Parser(protocol).feed(answer.data)[0].servo_id == answer.servo_id
    dropped = parser.drop()  # the line falls quiet: what is left is dropped
    if dropped is not None:
        bus.handle(dropped)
    first = bus.servos[0].servo_id  # a WRITE the flips made valid may have renamed it
    make = dxl_packet if protocol == "dynamixel" else sts_packet
    (ping,) = parser.feed(make(first, PING))
    assert [a.servo_id for a in bus.handle(ping)] == [first]
