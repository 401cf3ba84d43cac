"""TDM-PWM frame, edges and demultiplexer (hardware.tdm, hardware.demux): exact ticks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from hardware import (
    SERVO_NAMES,
    ChannelMap,
    FrameEdges,
    Pulse,
    TdmConfig,
    demultiplex,
    falling_edge_ticks,
    frame_edges,
    frame_ocr,
    guard_violations,
    ocr_to_pulse_us,
    select_value,
    servo_falling_edge_ticks,
    servo_frame_ocr,
    servo_guard_violations,
)

CONFIG = TdmConfig()
L_HIP_YAW, L_HIP_ROLL, L_ANKLE_ROLL, R_KNEE = 0, 1, 5, 9

# A known pulse set: 1000 + 100 * servo index (µs).
KNOWN_PULSES_US = 1000.0 + 100.0 * np.arange(12)
KNOWN_OCR = np.array(
    [
        [1999, 2199, 2399, 2599, 2799, -1, -1, -1],  # OC1A: left hip yaw .. left ankle pitch
        [3199, 3399, 3599, 3799, 3999, -1, -1, -1],  # OC1B: right hip yaw .. right ankle pitch
        [2999, -1, -1, -1, -1, -1, -1, -1],  # OC1C: l_ankle_roll
        [4199, -1, -1, -1, -1, -1, -1, -1],  # OC3A: r_ankle_roll
        [-1] * 8,
        [-1] * 8,
    ]
)


def centred_frame() -> np.ndarray:
    return frame_ocr(np.full(12, 1500.0), CONFIG)


def test_default_map() -> None:
    cmap = ChannelMap.default()
    assert cmap.assignments[:6] == ((0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (2, 0))
    assert cmap.assignments[6:] == ((1, 0), (1, 1), (1, 2), (1, 3), (1, 4), (3, 0))
    assert cmap.servo_at(1, 3) == R_KNEE
    assert cmap.servo_at(2, 0) == L_ANKLE_ROLL
    assert cmap.servo_at(2, 1) is None
    assert cmap.servo_at(5, 0) is None
    assert SERVO_NAMES[R_KNEE] == "r_knee"


def _map_with(servo: int, pair: tuple[int, int]) -> tuple[tuple[int, int], ...]:
    pairs = list(ChannelMap.default().assignments)
    pairs[servo] = pair
    return tuple(pairs)


@pytest.mark.parametrize(
    ("assignments", "message"),
    [
        (_map_with(0, (6, 0)), r"channel must be 0\.\.5"),
        (_map_with(0, (-1, 0)), r"channel must be 0\.\.5"),
        (_map_with(0, (4, 5)), r"slot must be 0\.\.4"),
        (_map_with(L_ANKLE_ROLL, (0, 2)), "l_hip_pitch and l_ankle_roll are both on OC1A slot 2"),
        (ChannelMap.default().assignments[:11], "one \\(channel, slot\\) per servo: 12"),
    ],
)
def test_channel_map_validation(assignments: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ChannelMap(assignments=assignments)


@pytest.mark.parametrize("ticks", [0, 5000, -3, 4900.0, True])
def test_config_validation(ticks: object) -> None:
    with pytest.raises(ValueError, match="select_change_ticks"):
        TdmConfig(select_change_ticks=ticks)  # type: ignore[arg-type]


def test_frame_ocr_table() -> None:
    ocr = frame_ocr(KNOWN_PULSES_US, CONFIG)
    assert ocr.dtype == np.int32
    assert np.array_equal(ocr, KNOWN_OCR)


def test_frame_ocr_vectorised_over_blocks() -> None:
    pulses = np.broadcast_to(KNOWN_PULSES_US, (3, 50, 12)).copy()
    pulses[1, 20, R_KNEE] = 2400.0
    ocr = frame_ocr(pulses, CONFIG)
    assert ocr.shape == (3, 50, 6, 8)
    assert ocr[1, 20, 1, 3] == 4799
    ocr[1, 20, 1, 3] = KNOWN_OCR[1, 3]
    assert np.all(ocr == KNOWN_OCR)


def test_frame_ocr_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 12\)"):
        frame_ocr(np.full(10, 1500.0), CONFIG)
    with pytest.raises(ValueError, match="NaN"):
        frame_ocr(np.full(12, np.nan), CONFIG)


def test_falling_edges_table() -> None:
    # slot * 5000 + OCR + 1: e.g. l_knee (slot 3, 1300 µs) falls at 15000 + 2600.
    expected = [2000, 7200, 12400, 17600, 22800, 3000, 3200, 8400, 13600, 18800, 24000, 4200]
    assert falling_edge_ticks(KNOWN_OCR, CONFIG).tolist() == expected


def test_falling_edge_slot_3_centred() -> None:
    assert falling_edge_ticks(centred_frame(), CONFIG)[R_KNEE] == 3 * 5000 + 3000 == 18000


def test_falling_edges_vectorised_and_idle() -> None:
    frames = np.stack([KNOWN_OCR, KNOWN_OCR])
    frames[1, 1, 3] = -1  # r_knee's slot idle in the second frame
    falls = falling_edge_ticks(frames, CONFIG)
    assert falls.shape == (2, 12)
    assert falls[0, R_KNEE] == 18800
    assert falls[1, R_KNEE] == -1


def test_guard_violation_cuts_pulse_and_glitches_next_output() -> None:
    ocr = centred_frame()
    ocr[0, 0] = 4950  # l_hip_yaw high until tick 4951, select lines change at 4900
    guard = guard_violations(ocr, CONFIG)
    assert guard[0, 0]
    assert np.count_nonzero(guard) == 1
    assert falling_edge_ticks(ocr, CONFIG)[L_HIP_YAW] == 4900

    result = demultiplex(frame_edges(ocr, CONFIG), CONFIG)
    assert result.pulse_us[L_HIP_YAW] == 2450.0  # cut at 4900 ticks
    assert result.cut[L_HIP_YAW] and not result.glitch[L_HIP_YAW]
    # The remainder 4900..4951 spills into output 1 before l_hip_roll's own pulse.
    assert result.outputs[0][1] == (Pulse(4900, 4951, False), Pulse(5000, 8000, False))
    assert result.glitch[L_HIP_ROLL] and not result.cut[L_HIP_ROLL]
    assert result.pulse_us[L_HIP_ROLL] == 25.5  # the first pulse it saw
    assert np.count_nonzero(result.glitch) == 1
    assert np.count_nonzero(result.cut) == 1


def test_guard_violation_from_an_early_select_change() -> None:
    # A 2.4 ms pulse (4800 ticks) is legal, but not if the select lines move at 2.35 ms.
    config = TdmConfig(select_change_ticks=4700)
    pulses = np.full(12, 1500.0)
    pulses[R_KNEE] = 2400.0
    ocr = frame_ocr(pulses, config)
    assert np.argwhere(guard_violations(ocr, config)).tolist() == [[1, 3]]
    assert falling_edge_ticks(ocr, config)[R_KNEE] == 15000 + 4700
    assert not guard_violations(ocr, CONFIG).any()


def test_pulse_ending_exactly_at_select_change_is_clean() -> None:
    ocr = centred_frame()
    ocr[0, 0] = 4899  # falls at 4900, the same tick the select lines switch
    assert not guard_violations(ocr, CONFIG).any()
    result = demultiplex(frame_edges(ocr, CONFIG), CONFIG)
    assert result.pulse_us[L_HIP_YAW] == 2450.0
    assert not result.glitch.any() and not result.cut.any()


def test_frame_edges_exact() -> None:
    edges = frame_edges(KNOWN_OCR, CONFIG)
    assert edges.names == ("OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C", "S0", "S1", "S2")
    assert edges.initial == (1, 1, 1, 1, 0, 0, 0, 0, 0)
    assert edges.line("OC1A") == (
        1,
        (
            (2000, 0),
            (5000, 1),
            (7200, 0),
            (10000, 1),
            (12400, 0),
            (15000, 1),
            (17600, 0),
            (20000, 1),
            (22800, 0),
        ),
    )
    assert edges.line("OC1C") == (1, ((3000, 0),))
    assert edges.line("OC3A") == (1, ((4200, 0),))
    assert edges.line("OC3B") == (0, ())
    # Select value k + 1 is written at k * 5000 + 4900; S0 toggles at every change.
    assert edges.line("S0")[1] == tuple((k * 5000 + 4900, (k + 1) % 2) for k in range(8))
    assert edges.line("S1")[1] == ((9900, 1), (19900, 0), (29900, 1), (39900, 0))
    assert edges.line("S2")[1] == ((19900, 1), (39900, 0))


def test_select_value_matches_select_edges() -> None:
    ticks = np.array([0, 4899, 4900, 9899, 9900, 34899, 34900, 39899, 39900, 39999])
    assert select_value(ticks, CONFIG).tolist() == [0, 0, 1, 1, 2, 6, 7, 7, 0, 0]


def test_frame_edges_rejects_batches_and_bad_ocr() -> None:
    with pytest.raises(ValueError, match=r"one frame of shape \(6, 8\)"):
        frame_edges(np.stack([KNOWN_OCR, KNOWN_OCR]), CONFIG)
    with pytest.raises(ValueError, match=r"-1 \(idle\) or 0\.\.4998"):
        frame_edges(np.full((6, 8), 4999), CONFIG)
    with pytest.raises(ValueError, match="integer"):
        guard_violations(np.zeros((6, 8)), CONFIG)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 6, 8\)"):
        falling_edge_ticks(np.zeros((8, 6), dtype=int), CONFIG)


def test_frame_edges_validation() -> None:
    good = frame_edges(KNOWN_OCR, CONFIG)
    with pytest.raises(ValueError, match="OC1A: edge ticks must increase"):
        FrameEdges(good.names, good.initial, (((5000, 0), (2000, 1)), *good.edges[1:]))
    with pytest.raises(ValueError, match="OC1A: levels must be 0 or 1 and change"):
        FrameEdges(good.names, good.initial, (((2000, 1),), *good.edges[1:]))


def test_stray_pulse_on_unassigned_output() -> None:
    ocr = centred_frame()
    ocr[4, 6] = 999  # OC3B slot 6 carries no servo
    result = demultiplex(frame_edges(ocr, CONFIG), CONFIG)
    assert result.stray == ((4, 6),)
    assert result.outputs[4][6] == (Pulse(30000, 31000, False),)


# Any 12 distinct (channel, slot) places among the 6 x 5 used ones.
channel_maps = st.permutations([(c, s) for c in range(6) for s in range(5)]).map(
    lambda places: ChannelMap(assignments=tuple(places[:12]))
)


@given(
    cmap=channel_maps,
    pulses=hnp.arrays(np.float64, 12, elements=st.floats(600.0, 2400.0)),
)
def test_demultiplex_round_trips_in_range_pulses(cmap: ChannelMap, pulses: np.ndarray) -> None:
    config = TdmConfig(channel_map=cmap)
    ocr = frame_ocr(pulses, config)
    result = demultiplex(frame_edges(ocr, config), config)
    servo_ocr = ocr[cmap.channel_index, cmap.slot_index]
    assert np.array_equal(result.pulse_us, ocr_to_pulse_us(servo_ocr))
    assert np.all(np.abs(result.pulse_us - pulses) <= 0.25)
    assert np.array_equal(result.fall_ticks, falling_edge_ticks(ocr, config))
    assert not result.glitch.any() and not result.cut.any() and result.stray == ()


@given(
    cmap=channel_maps,
    select_change=st.integers(1, 4999),
    servo_ocr=hnp.arrays(np.int32, 12, elements=st.integers(0, 4998)),
)
def test_demultiplex_agrees_with_vectorised_model(
    cmap: ChannelMap, select_change: int, servo_ocr: np.ndarray
) -> None:
    # Any OCR and select timing, guard violations included.
    config = TdmConfig(channel_map=cmap, select_change_ticks=select_change)
    ocr = np.full((6, 8), -1, dtype=np.int32)
    ocr[cmap.channel_index, cmap.slot_index] = servo_ocr
    result = demultiplex(frame_edges(ocr, config), config)
    guard = guard_violations(ocr, config)
    assert np.array_equal(result.cut, guard[cmap.channel_index, cmap.slot_index])
    # A glitch on output k has one cause: the pulse of slot k - 1 on the same line was cut.
    slots = cmap.slot_index
    prev_cut = (slots > 0) & guard[cmap.channel_index, np.maximum(slots - 1, 0)]
    assert np.array_equal(result.glitch, prev_cut)
    ok = ~result.glitch
    assert np.array_equal(result.fall_ticks[ok], falling_edge_ticks(ocr, config)[ok])


@given(
    cmap=channel_maps,
    select_change=st.integers(1, 4999),
    servo_ocr=hnp.arrays(np.int32, (3, 12), elements=st.integers(0, 4998)),
)
def test_the_servo_forms_give_what_the_frame_forms_give(
    cmap: ChannelMap, select_change: int, servo_ocr: np.ndarray
) -> None:
    # planning works from the servos' OCR without building and checking the frame each time
    config = TdmConfig(channel_map=cmap, select_change_ticks=select_change)
    ocr = servo_frame_ocr(servo_ocr, config)
    assert ocr.dtype == np.int32 and np.count_nonzero(ocr >= 0) == servo_ocr.size
    assert np.array_equal(ocr[:, cmap.channel_index, cmap.slot_index], servo_ocr)
    falls = servo_falling_edge_ticks(servo_ocr, config)
    assert falls.dtype == np.int64
    assert np.array_equal(falls, falling_edge_ticks(ocr, config))
    assert np.array_equal(servo_guard_violations(servo_ocr, config), guard_violations(ocr, config))


def test_the_channel_maps_indexes_are_kept_and_read_only() -> None:
    cmap = ChannelMap.default()
    assert cmap.slot_index is cmap.slot_index
    with pytest.raises(ValueError, match="read-only"):
        cmap.channel_index[0] = 3
