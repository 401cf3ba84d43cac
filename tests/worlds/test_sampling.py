"""Samples of variations (`app/worlds/sampling.py`, docs/DESIGN.md §8): a seed gives the same
sample to the bit, the draws fill their ranges, narrowing one range keeps the other draws, and
the sensors' draws leave the physics' alone. Split from test_variations.py."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.worlds.sampling import DIRECTIONS, SAMPLE_COLUMNS, VariationRanges, sample
from app.worlds.variations import FIELDS
from tests.worlds.test_variations import bits


def test_the_same_seed_gives_the_same_sample_to_the_bit_and_another_seed_another():
    ranges = VariationRanges()
    first = sample(ranges, 40, seed=7)
    assert [bits(v) for v in sample(ranges, 40, seed=7)] == [bits(v) for v in first]
    assert [v.name for v in sample(ranges, 40, seed=8)] != [v.name for v in first]
    assert sample(ranges, 10, seed=7) == first[:10]  # a prefix of a longer draw
    assert len({v.name for v in first}) == 40
    # the table is PCG64's raw 64-bit stream cut to 53-bit doubles (numpy keeps bit streams
    # stable across versions), and the first row is the first variation
    raw = np.random.PCG64(7).random_raw(2 * len(SAMPLE_COLUMNS))
    u = (raw >> np.uint64(11)) * 2.0**-53
    table = np.random.Generator(np.random.PCG64(7)).random((2, len(SAMPLE_COLUMNS)))
    assert table.tobytes() == u.tobytes()
    assert first[0].friction == round(0.4 + 0.6 * u[0], 3)
    assert first[0].calibration_deg[-1] == round(-1.5 + 3.0 * u[len(SAMPLE_COLUMNS) - 1], 2)
    # on every machine: the first variation of seed 0, as printed by this code on numpy 2.4
    assert sample(ranges, 1, seed=0)[0].name.startswith(
        "friction=0.782,trunk_mass_scale=0.931,link_mass_scale=0.908,kp_scale=0.807,"
    )


def test_samples_fill_their_ranges_and_narrowing_one_range_keeps_the_other_draws():
    ranges = VariationRanges().with_range("push_n_s", 0.2, 1.0)  # (no push by default)
    drawn = sample(ranges, 400, seed=11)
    for field in FIELDS:
        low, high = getattr(ranges, field)
        values = np.array([getattr(v, field) for v in drawn], dtype=float)
        if field in DIRECTIONS:
            high = 360.0 - 0.1
        assert values.min() >= low and values.max() <= high, field
        assert values.min() < low + 0.05 * (high - low) and values.max() > high - 0.05 * (
            high - low
        ), field
    narrow = sample(ranges.with_range("friction", 0.3, 0.3).with_range("latency_ms", 5, 9), 400, 11)
    assert {v.friction for v in narrow} == {0.3}
    assert {v.latency_ms for v in narrow} <= {5.0, 6.0, 7.0, 8.0, 9.0}
    for a, b in zip(drawn, narrow, strict=True):
        assert dataclasses.replace(a, friction=0.3, latency_ms=b.latency_ms) == b


def test_the_sensors_draws_leave_the_physics_draws_and_no_push_leaves_no_push_fields():
    """The sensors' errors come from a stream of their own: widening or narrowing their ranges
    leaves the physics drawn for a seed as they were; without a push its time and direction
    stay at 0, so a variation's name does not carry them."""
    plain = sample(VariationRanges(), 50, seed=3)
    other = (
        VariationRanges()
        .with_range("gyro_noise_deg_s", 0.0, 1.0)
        .with_range("imu_delay_ms", 0.0, 40.0)
    )
    assert [v.physics for v in sample(other, 50, seed=3)] == [v.physics for v in plain]
    assert all(v.push_n_s == v.push_time_s == v.push_direction_deg == 0.0 for v in plain)
    assert all("push" not in v.name for v in plain)
    assert all(v.physics.is_nominal is False and v.imu_delay_ms >= 2.0 for v in plain)
