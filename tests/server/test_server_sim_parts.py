"""Parts of the simulation thread on their own: the pacing on a clock the test moves (no waiting),
and the typed commands, refused where they are made when they are bad."""

from __future__ import annotations

import threading

import pytest

from app.server.sim.pacing import BEHIND_SHOWN_S, MAX_CATCHUP_FRAMES, Pacer
from app.server.sim.sim_commands import (
    CONTROLS,
    CommandQueue,
    Pause,
    Reanchor,
    Reset,
    Resume,
    SetGhost,
    SetSpeed,
    SetWorld,
    Step,
    SwitchDrive,
    control,
)
from app.sim.planning import FRAME_S
from app.worlds.variations import NOMINAL
from gait import GaitParams


class FakeClock:
    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def test_frames_fall_due_on_the_wall_clock_at_the_speed_asked() -> None:
    clock = FakeClock()
    pacer = Pacer(clock)
    assert pacer.frames_due() == 0
    clock.now_s += 3 * FRAME_S + 1e-9
    assert pacer.frames_due() == 3
    for _ in range(3):
        pacer.frame_done()
    assert pacer.frames_due() == 0
    assert pacer.wait_s() == pytest.approx(FRAME_S - 1e-9)
    pacer.set_speed(2.0)  # twice real time: a frame every 10 ms of wall time, from now
    clock.now_s += 2 * FRAME_S + 1e-9
    assert pacer.frames_due() == 4


def test_a_debt_beyond_the_catch_up_is_dropped_counted_and_shown_for_a_while() -> None:
    clock = FakeClock()
    pacer = Pacer(clock)
    clock.now_s += 12 * FRAME_S + 1e-9
    assert pacer.frames_due() == MAX_CATCHUP_FRAMES
    assert pacer.frames_dropped == 12 - MAX_CATCHUP_FRAMES
    assert pacer.behind()
    for _ in range(MAX_CATCHUP_FRAMES):
        pacer.frame_done()
    assert pacer.frames_due() == 0  # the dropped frames are not owed any more
    clock.now_s += BEHIND_SHOWN_S
    assert not pacer.behind()
    assert pacer.frames_dropped == 12 - MAX_CATCHUP_FRAMES  # the count stays


def test_the_real_time_factor_is_measured_over_its_window_and_restarts_with_a_reset() -> None:
    clock = FakeClock()
    pacer = Pacer(clock)
    assert pacer.rtf() is None
    for k in range(200):  # 4 s of wall time, simulated at half speed
        pacer.sample(sim_time_s=k * 0.01)
        clock.now_s += 0.02
    assert pacer.rtf() == pytest.approx(0.5)
    pacer.clear_rtf()
    assert pacer.rtf() is None


@pytest.mark.parametrize("speed", [0.1, 5.0, "2", True, float("nan")])
def test_a_speed_out_of_range_is_refused_where_it_is_made(speed: object) -> None:
    with pytest.raises(ValueError, match=r"speed must be 0\.25 to 4\.0"):
        SetSpeed(speed)  # type: ignore[arg-type]


def test_bad_command_values_are_refused_where_they_are_made() -> None:
    with pytest.raises(ValueError, match="Variation"):
        SetWorld("friction=0.4")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="GaitParams"):
        SetGhost({"engine": "behnke"}, "a dict")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="EmulatedController or None"):
        SwitchDrive("firmware")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="finite speed"):
        Reanchor(float("inf"))
    assert SetSpeed(2).speed == 2.0 and isinstance(SetSpeed(2).speed, float)
    assert SetGhost(GaitParams(), "paper").source == "paper"
    assert SetWorld(NOMINAL).variation is NOMINAL


def test_the_controls_by_name_and_an_unknown_one() -> None:
    assert [type(c) for c in CONTROLS.values()] == [Reset, Pause, Resume, Step]
    assert control("step") == Step()
    with pytest.raises(ValueError, match="unknown command 'jump'; allowed: reset, pause"):
        control("jump")


def test_the_queue_keeps_the_order_wakes_the_thread_and_takes_only_commands() -> None:
    wake = threading.Event()
    commands = CommandQueue(wake)
    commands.put(Pause())
    assert wake.is_set()
    commands.put(SetSpeed(0.5))
    commands.put(Resume())
    assert list(commands.drain()) == [Pause(), SetSpeed(0.5), Resume()]
    assert list(commands.drain()) == []
    with pytest.raises(ValueError, match="not a command"):
        commands.put("pause")  # type: ignore[arg-type]


def test_published_poses_name_the_model_they_are_poses_of(sim_thread):
    """The 3D view draws poses only on the model they are of: for a refresh after a switch of
    robots it drew the new robot's bodies in the last robot's poses (the thread audit)."""
    from tests.testing.server_harness import wait_for

    sim, store = sim_thread
    sim.publish_poses = True
    first = wait_for(lambda: sim.body_poses(), "poses published")
    artro = sim.model
    assert first.model is artro and len(first.xpos) == artro.nbody
    store.replace(store.snapshot().parameter_set(), "test", robot="micro")
    wait_for(lambda: sim.status().robot == "micro", "the simulation took the micro robot")
    poses = wait_for(
        lambda: (p := sim.body_poses()) and p.model is not artro and p, "the micro robot's poses"
    )
    assert poses.model is sim.model and sim.model is not artro
