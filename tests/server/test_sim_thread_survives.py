"""The simulation thread outlives what it is sent (docs/DESIGN.md §10): a world that cannot be
simulated is dropped, said so, and the robot walks on; physics that blows up at every start
pauses the robot with one line naming the world instead of resetting every frame. The worlds
and pushes here are forced past their checks (which refuse them,
tests/worlds/test_variations.py), as a bug elsewhere could: the thread must not depend on every
caller being right."""

from __future__ import annotations

import dataclasses

from app.server.sim.sim_commands import Pause, Push, Reset, Resume, SetWorld, Step
from app.worlds.variations import NOMINAL, Variation
from tests.testing.server_harness import wait_for


def forced(**values: float) -> Variation:
    """A variation holding `values` although its checks would refuse them."""
    variation = Variation()
    for name, value in values.items():
        object.__setattr__(variation, name, value)
    return variation


def test_a_world_that_cannot_be_simulated_is_dropped_and_the_robot_walks_on(sim_thread):
    sim, _store = sim_thread
    sim.send(SetWorld(dataclasses.replace(NOMINAL, friction=0.6)))
    wait_for(lambda: sim.status().world == "friction=0.6", "the first world taken")
    sim.send(SetWorld(forced(latency_ms=1e308)))  # a queue of 1e305 steps: OverflowError
    wait_for(lambda: any("could not be simulated" in e for e in sim.status().errors), "said so")
    frame = sim.status().frame
    wait_for(lambda: sim.status().frame > frame + 10, "the robot walks on")
    assert sim.alive and sim.status().world == "friction=0.6" and not sim.status().paused
    (said,) = [e for e in sim.status().errors if "could not be simulated" in e]
    assert "latency_ms=1e+308" in said and "stays in friction=0.6" in said


def test_physics_that_blows_up_at_every_start_pauses_once_naming_the_world(sim_thread):
    sim, _store = sim_thread
    sim.send(SetWorld(dataclasses.replace(NOMINAL, friction=0.6)))
    sim.send(Pause())
    sim.send(Reset())
    wait_for(lambda: sim.status().world == "friction=0.6" and sim.status().paused, "paused")
    for blow_up in (1, 2):  # each a frame after the robot was stood up: "at once"
        resets = sim.status().resets
        sim.send(forced_push(1e300))  # 1e303 N for a step: NaN in the state
        sim.send(Step())
        wait_for(lambda r=resets: sim.status().resets == r + 1, f"blow-up {blow_up} reset")
    errors = sim.status().errors
    assert "physics blew up" in errors[-2] and "robot reset" in errors[-2]
    assert "blows up within 1 s of every start in the world friction=0.6" in errors[-1]
    assert "paused" in errors[-1] and sim.status().paused and sim.alive
    sim.send(Resume())
    frame = sim.status().frame
    wait_for(lambda: sim.status().frame > frame + 10, "it walks again when resumed")
    assert not sim.status().fell and len(sim.status().errors) == len(errors)


def forced_push(impulse_n_s: float) -> Push:
    """A push of `impulse_n_s` although its checks would refuse it."""
    push = Push(1.0)
    object.__setattr__(push, "impulse_n_s", impulse_n_s)
    return push


def test_a_change_of_robots_is_no_negative_latency(sim_thread):
    """`param_latency_frames` once read -1312 after a switch of robots: the frames are counted
    anew by the new robot's loop, so a change that waited across it is not measured."""
    sim, store = sim_thread
    wait_for(lambda: sim.status().frame > 60, "some frames walked")
    assert sim.status().param_latency_frames.count == 0  # nothing changed yet
    store.replace(store.snapshot().parameter_set(), "test", robot="micro")
    wait_for(lambda: sim.status().robot == "micro", "the micro robot simulated")
    latency = sim.status().param_latency_frames
    assert latency.count == 0 or latency.median >= 0, latency
