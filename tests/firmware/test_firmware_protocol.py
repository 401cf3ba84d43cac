"""The firmware's UART protocol on the emulated ATmega128, and the emulator corrections.

A parameter set sent over the link changes the pulses from the frame its ACK names; every class of
bad message gets its NAK and changes nothing (parameters read back, pulses against the model).
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from app.firmware import protocol as proto
from app.firmware.build import build_firmware
from app.firmware.conformance import model_frames, run_comparison, split_frames
from app.firmware.emulator import FRAME_CYCLES, Mcu, read_active_plan
from app.firmware.link import EmulatedLink, read_params
from app.firmware.protocol import Ack, Info, Msg, Nak, NakReason, Telemetry
from app.sim.planning import START_PHASE_RAD
from gait import GaitParams, Motion, joint_angles
from hardware import ServoCalibration, angles_to_pulses_us, pulse_us_to_ocr
from hardware.firmware.schema import param_specs, schema_hash, values_from_document
from tests.testing.firmware_support import emulator, preset

SPECS = {spec.dotted: spec for spec in param_specs()}


def frame_now(mcu: Mcu) -> int:
    return (mcu.cycle - mcu.t0_cycle) // FRAME_CYCLES


def assert_unchanged(mcu: Mcu, link: EmulatedLink, doc: dict, n_frames: int) -> None:
    expected = np.float32(values_from_document(doc))
    np.testing.assert_array_equal(np.float32(read_params(link, len(SPECS))), expected)
    result = run_comparison(mcu, model_frames(doc, n_frames))
    assert result.mismatches == [] and result.one_tick <= 1, result.mismatches[:3]


def test_ping_reports_the_schema() -> None:
    with emulator(preset("paper")) as mcu:
        (info,) = EmulatedLink(mcu).request(proto.command(Msg.PING))
    assert isinstance(info, Info)
    assert info.version == proto.VERSION and info.param_count == len(SPECS)
    assert info.schema_hash == schema_hash() and info.state == proto.RunState.WALK


def test_a_parameter_set_over_the_uart_changes_the_pulses_from_the_acked_frame() -> None:
    old, new = preset("paper", a_p=0.07), preset("tuned", a_r=0.05, ca=0.1)
    with emulator(old) as mcu:
        link = EmulatedLink(mcu)
        mcu.run_to_frame(6, 1000)
        sent_in = frame_now(mcu)
        # the gait's ids (and the first laws'): the laws' values are the same in both sets
        (ack,) = link.request(proto.set_params(values_from_document(new)[: proto.MAX_VALUES]))
        acked_in = frame_now(mcu)
        assert isinstance(ack, Ack) and ack.acked == Msg.SET_PARAMS
        # the next frame still to be planned: planning happens in slot 5 of the frame before
        assert sent_in + 1 <= ack.effective_frame <= acked_in + 2
        n_frames = ack.effective_frame + 60
        model = model_frames(old, n_frames, changes=[(ack.effective_frame, new)])
        result = run_comparison(mcu, model)
    assert result.mismatches == [], result.mismatches[:3]
    assert result.one_tick <= 0.01 * result.pulses
    # and the change is visible: the old set's model differs from the new one from there on
    unchanged = model_frames(old, n_frames)
    assert np.any(unchanged.ocr[ack.effective_frame] != model.ocr[ack.effective_frame])
    assert np.all(unchanged.ocr[: ack.effective_frame] == model.ocr[: ack.effective_frame])


def _bad_messages() -> list[tuple[str, bytes, NakReason, int]]:
    swing_v = SPECS["swing.v"].pid
    good = proto.set_param(swing_v, 2.5)
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0x55
    values = values_from_document(preset("tuned"))
    values[SPECS["short.o"].pid] = 5.0  # one bad value in a whole set
    return [
        ("checksum", bytes(bad_crc), NakReason.BAD_CRC, Msg.SET_PARAM),
        ("unknown type", proto.encode(0x42, b"\x00"), NakReason.UNKNOWN_TYPE, 0x42),
        ("length", proto.encode(Msg.SET_PARAM, b"\x11\x00\x00"), NakReason.BAD_LENGTH, 3),
        ("zero length", bytes([proto.SYNC, 0, 0, 0]), NakReason.BAD_LENGTH, 0),
        ("unknown id", proto.set_param(len(SPECS), 1.0), NakReason.UNKNOWN_ID, Msg.SET_PARAM),
        ("unknown id get", proto.get_param(200), NakReason.UNKNOWN_ID, Msg.GET_PARAM),
        ("above range", proto.set_param(swing_v, 9.5), NakReason.OUT_OF_RANGE, Msg.SET_PARAM),
        ("nan", proto.set_param(swing_v, math.nan), NakReason.OUT_OF_RANGE, Msg.SET_PARAM),
        (
            "switch not 0/1",
            proto.set_param(SPECS["leg.paper_signs"].pid, 0.5),
            NakReason.OUT_OF_RANGE,
            Msg.SET_PARAM,
        ),
        (
            "motion out of range",
            proto.set_motion(0.0, 0.07, 1.0, 0.0),
            NakReason.OUT_OF_RANGE,
            Msg.SET_MOTION,
        ),
        (
            "one bad value in a set",
            proto.set_params(values[: proto.MAX_VALUES]),
            NakReason.OUT_OF_RANGE,
            Msg.SET_PARAMS,
        ),
        (
            "too many values in a set",
            proto.encode(Msg.SET_PARAMS, bytes([0, 49]) + bytes(4 * 49)),
            NakReason.BAD_LENGTH,
            Msg.SET_PARAMS,
        ),
        ("truncated", good[:5], NakReason.TIMEOUT, Msg.SET_PARAM),
    ]


BAD = _bad_messages()


def test_every_bad_message_gets_its_nak_and_changes_nothing() -> None:
    doc = preset("paper", a_p=0.07)
    with emulator(doc) as mcu:
        link = EmulatedLink(mcu)
        for name, message, reason, rejected in BAD:
            (reply,) = link.request(message)
            assert isinstance(reply, Nak), name
            assert reply.reason == reason, name
            if reason not in (NakReason.BAD_LENGTH,):
                assert reply.rejected == rejected, name
        assert frame_now(mcu) < 40
        # the link still works, and nothing changed: parameters, and every pulse since reset
        (info,) = link.request(proto.command(Msg.PING))
        assert isinstance(info, Info)
        assert_unchanged(mcu, link, doc, 50)


def test_stray_sync_bytes_before_a_message_cost_nothing() -> None:
    """No message is 165 long, so a 0xA5 where a LEN belongs starts the message anew."""
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        for noise in (b"\xa5", b"\xa5\xa5\xa5", b"\x00\xa5"):
            (reply,) = link.request(noise + proto.command(Msg.PING))
            assert isinstance(reply, Info), (noise, reply)
    with pytest.raises(ValueError, match="164 bytes is reserved"):
        proto.encode(Msg.SET_PARAMS, bytes(164))


def test_nak_details_name_the_offending_id() -> None:
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        bad_set = next(message for name, message, *_ in BAD if name == "one bad value in a set")
        (nak,) = link.request(bad_set)  # the gait's ids with short.o out of range
        assert isinstance(nak, Nak) and nak.detail == SPECS["short.o"].pid
        (nak,) = link.request(proto.set_param(250, 0.0))
        assert isinstance(nak, Nak) and nak.detail == 250
        count = len(SPECS)  # of a range, its first id that does not exist
        for first, named in ((250, 250), (count - 2, count)):
            (nak,) = link.request(proto.set_params([0.0] * 5, first=first))
            assert isinstance(nak, Nak) and nak.reason == NakReason.UNKNOWN_ID
            assert nak.detail == named, first
            (nak,) = link.request(proto.get_params(first, 5))
            assert isinstance(nak, Nak) and nak.reason == NakReason.UNKNOWN_ID
            assert nak.detail == named, first


def test_torque_off_stop_and_start() -> None:
    doc = preset("paper", a_p=0.07)
    with emulator(doc) as mcu:
        link = EmulatedLink(mcu)
        (ack,) = link.request(proto.command(Msg.TORQUE_OFF))
        off = ack.effective_frame
        mcu.run_to_frame(off + 3)
        (ack,) = link.request(proto.command(Msg.STOP))
        stop = ack.effective_frame
        mcu.run_to_frame(stop + 4)
        (ack,) = link.request(proto.command(Msg.START))
        start = ack.effective_frame
        mcu.run_to_frame(start + 3)
        frames = split_frames(mcu.take_edges(), mcu.t0_cycle, start + 3)
        plan = read_active_plan(mcu)
    channels = slice(0, 6)
    for k in range(off, stop):  # no pulses at all
        assert not any(frames[k].initial[channels]) and not any(frames[k].edges[channels])
    held = [frames[k].edges[channels] for k in range(stop + 1, start)]
    assert all(edges == held[0] for edges in held) and any(held[0])  # the pose held
    assert frames[start + 1].edges[channels] != frames[start].edges[channels]  # walking again
    assert plan.state == proto.RunState.WALK


def test_telemetry_every_frame_carries_the_model_pulses() -> None:
    doc = preset("tuned", a_p=0.05)
    model = model_frames(doc, 30)
    with emulator(doc) as mcu:
        link = EmulatedLink(mcu)
        link.request(proto.telemetry_on(1))
        link.run(20 * FRAME_CYCLES)
    frames = [t.frame for t in link.telemetry]
    assert frames == list(range(frames[0], frames[0] + len(frames))) and len(frames) >= 18
    mapping = np.array([[c, s] for c, s in _channel_map()])
    for t in link.telemetry:
        assert isinstance(t, Telemetry)
        want = model.ocr[t.frame][mapping[:, 0], mapping[:, 1]]
        assert np.max(np.abs(np.array(t.ocr) - want)) <= 1
        assert abs(t.phase_rad - model.phase[t.frame]) < 1e-6


def _channel_map() -> tuple[tuple[int, int], ...]:
    from hardware import ChannelMap

    return ChannelMap.default().assignments


def test_angles_over_the_link_match_the_gait() -> None:
    doc = preset("paper", a_r=0.1)
    with emulator(doc) as mcu:
        link = EmulatedLink(mcu)
        (angles,) = link.request(proto.command(Msg.GET_ANGLES))
    model = model_frames(doc, angles.frame + 1)
    assert np.max(np.abs(np.array(angles.angles_rad) - model.angles[angles.frame])) < 1e-4


# --- the emulator's corrections --------------------------------------------------------------


def test_without_the_mode14_correction_the_pulses_come_out_wrong() -> None:
    doc = preset("paper", a_p=0.07)
    elf = build_firmware(doc).elf
    with Mcu(elf, fix_mode14=False) as mcu:
        broken = run_comparison(mcu, model_frames(doc, 4))
    with Mcu(elf) as mcu:
        fixed = run_comparison(mcu, model_frames(doc, 4))
    assert len(broken.mismatches) > 10 and fixed.mismatches == []


def test_without_the_ocr_high_byte_correction_a_pulse_is_lost() -> None:
    """A slot-0 OCR whose low byte equals the idle slots' 0: simavr drops the write."""
    doc = preset("paper")
    angles = joint_angles(GaitParams.from_dict(doc["gait"]), Motion(), START_PHASE_RAD)
    servo = 5  # l_ankle_roll, alone on OC1C slot 0; slots 1-4 of OC1C are idle (OCR 0)
    pulse, _ = angles_to_pulses_us(angles, ServoCalibration.default())
    trim = np.zeros(12)
    trim[servo] = (0x0C00 + 1) * 0.5 - pulse[servo]  # OCR = 0x0C00
    cal = ServoCalibration(np.ones(12, np.int64), trim, np.full(12, -1.5), np.full(12, 1.5))
    build = build_firmware(doc, calibration=cal, defines={"ARTRO_BOOT_STATE": "1"})  # pose held
    assert int(pulse_us_to_ocr(pulse[servo] + trim[servo])) == 0x0C00
    falls = {}
    for fixed in (True, False):
        with Mcu(build.elf, fix_ocr_high_byte=fixed) as mcu:
            mcu.run_to_frame(3)
            frames = split_frames(mcu.take_edges(), mcu.t0_cycle, 3)
        falls[fixed] = frames[2].line("OC1C")[1][0]
    assert falls[True] == (0x0C01, 0)
    assert falls[False] != (0x0C01, 0)


@pytest.mark.parametrize("value", [0.3, -0.3])
def test_range_ends_are_accepted(value: float) -> None:
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        (ack,) = link.request(proto.set_param(SPECS["motion.a_p"].pid, value))
        (param,) = link.request(proto.get_param(SPECS["motion.a_p"].pid))
    as_float32 = struct.unpack("<f", struct.pack("<f", value))[0]
    assert isinstance(ack, Ack) and param.values[0] == as_float32
