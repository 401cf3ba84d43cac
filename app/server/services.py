"""The composition root of `artro serve`: the store, the simulation thread, presets, the 3D view."""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco

from app.analysis.robot_start import start_set
from app.params.document import ParameterSet
from app.params.formats import load_parameter_set
from app.params.presets import PresetStore, builtin_presets, default_data_dir
from app.robots.model import RobotModel
from app.server.feeds.robot_sensors import RobotSensors
from app.server.http.request_gate import served_hosts
from app.server.jobs.axle_fitter import AxleFitter
from app.server.jobs.ca_calibrator import CaCalibrator
from app.server.jobs.fit_job import FitRunner
from app.server.jobs.registry import Jobs
from app.server.jobs.robot_importer import IMPORT_TIMEOUT_S, RobotImporter
from app.server.jobs.robustness_job import RobustnessRunner
from app.server.jobs.tune_job import TuneRunner
from app.server.param_store import ParameterStore, RobotBusy, Snapshot
from app.server.recording.replay import Replay
from app.server.recording.sensor_trace import SensorView
from app.server.robot_shelf import RobotShelf
from app.server.sim.bus_port import BusPort
from app.server.sim.ghost import GhostStatus
from app.server.sim.live_robot import Drive
from app.server.sim.published import SimStatus
from app.server.sim.sim_commands import Push, SetWorld, SimCommand
from app.server.sim.sim_thread import SimThread
from app.sim.servo_load import ServoLoadReport
from app.worlds.fitted import fitted_variation
from hardware import HardwareSetup


@dataclass(frozen=True)
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = 8000
    viser_port: int = 8080
    params_file: Path | None = None
    data_dir: Path = field(default_factory=default_data_dir)
    viewer: bool = True  # start the viser 3D view
    allowed_hosts: tuple[
        str, ...
    ] = ()  # more Host names to answer to (app/server/http/request_gate.py)
    drive: str = "model"  # who makes the pulses at the start: "model" or "firmware"
    board: str | None = None  # the firmware drive's board (docs/BOARDS.md; default: the robot's)
    robot: str | None = None  # a built-in robot's name or a description file (default: artro)
    cluster: str | None = None  # a Dask scheduler for the robustness and fit jobs (default: local)
    wait_workers_s: float | None = None  # how long the job waits for a worker (default 60 s)
    backend: str = "cpu"  # the robustness job's: "warp" or "auto" for MuJoCo Warp (docs/GPU.md)
    device: str | None = None  # of the warp backend (default cuda)
    robot_import_timeout_s: float = IMPORT_TIMEOUT_S  # a dashboard import's child, at most
    servo_bus: str | None = None  # "pty": the leg servos answer on a pseudo-terminal (docs/BUS.md)
    bus_protocol: str = "dynamixel"  # the servo bus's protocol: "dynamixel" or "feetech"


class Services:
    def __init__(self, config: ServerConfig) -> None:
        self.config = config
        builtins = builtin_presets()
        self.robots = RobotShelf(RobotModel.load(config.robot))
        started = self.robots.started
        #: the dashboard's imports, each in its folder under the data folder's robots/
        self.importer = RobotImporter(
            self.robots, config.data_dir / "robots", config.robot_import_timeout_s
        )
        self.presets = PresetStore(config.data_dir, builtins)
        if config.params_file:
            initial = load_parameter_set(config.params_file)
        else:  # the robot's own preset: a new user should see a robot that walks
            initial = self.default_preset(started)
        self.store = ParameterStore(initial, robot=started.name)
        self.store.robot_guard = self._robot_free  # every change of robots, however made
        self.robot_sensors = RobotSensors()  # a linked robot's, from `artro link` (§15)
        self.sim = SimThread(self.store, robot=started, robots=self.robots.get)
        self.replay = Replay(self.sim.model, self.sim.recorder, self.sim)
        #: held while a recording file is read and checked: one import at a time
        self.importing = threading.Lock()
        if started.description.fitted is not None:  # a fitted robot walks its fit (docs/FIT.md)
            self.sim.send(SetWorld(fitted_variation(started)))
        self.bus_port: BusPort | None = None  # `--servo-bus pty`: the servos on a bus
        if config.servo_bus == "pty":
            self.bus_port = BusPort(started, config.bus_protocol)
            self.sim.live.bus_port = self.bus_port  # before the simulation thread starts
        self.sim.live.board = config.board  # before the simulation thread starts
        if config.drive != "model":
            self.sim.switch_drive(config.drive)  # taken over at the first frame
        self.paths, self.scope, self.recorder = self.sim.paths, self.sim.scope, self.sim.recorder
        #: the one job registry (GET /api/jobs/{id}), handed to every kind of job: a new kind is
        #: added by giving it this registry; each job walks the robot of the version it starts from
        self.jobs = Jobs()
        self.jobs.robot_in_use = self.store.settled_robot
        robot_now = self._robot_now
        self.axle_fitter = AxleFitter(jobs=self.jobs, store=self.store, robot_now=robot_now)
        self.ca_calibrator = CaCalibrator(self.jobs, self.store, self.paths, robot_now)
        self.robustness = RobustnessRunner(
            self.jobs,
            self.store,
            robot_now,
            config.cluster,
            backend={"backend": config.backend, "device": config.device},
            wait_workers_s=config.wait_workers_s,
        )
        self.tuner = TuneRunner(self.jobs, self.store, self.presets, robot_now)
        self.fitter = FitRunner(
            self.jobs,
            config.data_dir,
            robot_now,
            cluster=config.cluster,
            wait_workers_s=config.wait_workers_s,
        )
        self.viewer = None
        if config.viewer:
            from app.server.view.viser_gate import gate_viser
            from app.server.view.viser_view import (
                Viewer,  # viser is only loaded when the view is wanted
            )

            self.viewer = Viewer(
                store=self.store,
                sim=self.sim,
                paths=self.sim.paths,
                axle_fitter=self.axle_fitter,
                ca_calibrator=self.ca_calibrator,
                presets=self.presets,
                replay=self.replay,
                model=self.sim.model,
                host=config.host,
                port=config.viser_port,
            )
            gate_viser(self.viewer.server, served_hosts(config.host, config.allowed_hosts))
            bound = self.viewer.server.get_port()
            if config.viser_port not in (0, bound):  # taken: viser went on to the next free one
                print(
                    f"artro serve: port {config.viser_port} is taken; the 3D view alone is on "
                    f"{bound} (GET /api/health says so too)",
                    file=sys.stderr,
                    flush=True,
                )

    # --- what the routers use: the simulation thread's parts stay behind these ------------------

    def snapshot(self) -> Snapshot:
        """The parameter store's current version."""
        return self.store.snapshot()

    def send(self, command: SimCommand) -> None:
        """A command for the simulation thread's next frame boundary (`SimThread.send`)."""
        self.sim.send(command)

    def push(self, push: Push) -> None:
        """Push the live robot (`SimThread.push`: PushRefused where too many wait)."""
        self.sim.push(push)

    def switch_drive(self, drive: str) -> None:
        """Switch who makes the pulses (`SimThread.switch_drive`, its errors)."""
        self.sim.switch_drive(drive)

    def sim_status(self) -> SimStatus:
        """What the simulation thread published last."""
        return self.sim.status()

    def ghost_status(self) -> GhostStatus | None:
        return self.sim.ghost_status()

    def servo_load(self) -> ServoLoadReport:
        return self.sim.servo_load()

    def sensor_view(self) -> SensorView | None:
        return self.sim.sensor_view()

    def replay_status(self) -> dict[str, Any]:
        return self.replay.status()

    @property
    def running(self) -> bool:
        """Whether the simulation thread runs."""
        return self.sim.alive

    @property
    def hardware(self) -> HardwareSetup:
        """The simulated robot's hardware (replaced whole on a switch of robots)."""
        return self.sim.hardware

    @property
    def model(self) -> mujoco.MjModel:
        """The simulated robot's compiled model (replaced whole on a switch of robots)."""
        return self.sim.model

    @property
    def viser_port(self) -> int | None:
        """The port the 3D view is on (viser takes the next free one), None without it."""
        return None if self.viewer is None else self.viewer.server.get_port()

    @property
    def robot(self) -> RobotModel:
        """The robot of the parameter version in use (the simulation follows it within a frame)."""
        return self.robots.get(self.store.robot)

    def _robot_now(self) -> RobotModel:
        return self.robot

    def default_preset(self, robot: RobotModel) -> ParameterSet:
        """The set `robot` starts in: the preset it names (built in), or the newest saved one
        tuned for it where that was tuned for another robot (`PresetStore.start_for`)."""
        chosen = self.presets.start_for(robot.name, robot.description.default_preset)
        return start_set(robot.description, chosen)  # another robot's: scaled to these legs

    def switch_robot(self, name: str) -> tuple[Snapshot, bool]:
        """Simulate the robot `name` from the next frame, standing at the start in its default
        preset: a new parameter version, which undo takes back. (snapshot, whether it changed).
        UnknownRobot for a robot not on offer; RobotBusy, with nothing changed, while a job or
        a replay runs or the firmware drives (which are all for the robot in use)."""
        robot = self.robots.get(name)  # built here, in the caller's thread
        if robot.name == self.store.robot:
            return self.store.snapshot(), False
        return self.store.replace(self.default_preset(robot), "robot", robot=robot.name), True

    def _robot_free(self, current: Snapshot, robot: str) -> None:
        """The store's robot guard: a change from `current`'s robot to `robot` (a switch, an
        undo or a redo, from the API or the 3D view) is refused while a job, a replay or the
        firmware drive is on the robot in use. A firmware booting meanwhile is refused when
        handed over (`LiveRobot.take_drive`); a job's result applies only on its own robot."""
        change = f"changing the robot from {current.robot!r} to {robot!r}"
        if running := self.jobs.running():
            jobs = ", ".join(f"{job.kind} {job.id}" for job in running)
            cancel = " or ".join(f"DELETE /api/jobs/{job.id}" for job in running)
            raise RobotBusy(
                f"a job runs on {current.robot!r} ({jobs}): wait for it or cancel it "
                f"({cancel}) before {change}"
            )
        if self.replay.active:
            raise RobotBusy(
                f"a replay is shown: go back to live (POST /api/recording/live) before {change}"
            )
        if self.sim.status().drive != Drive.MODEL.value:
            raise RobotBusy(
                f"the firmware drives {current.robot!r}: switch the drive to the model "
                f"(PUT /api/sim/drive) before {change}"
            )

    def robot_warnings(self, pset: ParameterSet) -> list[str]:
        """What to tell a user who loads `pset` here: that it was tuned for another robot."""
        if pset.robot == self.robot.name:
            return []
        return [
            f"parameter set {pset.name!r} was tuned for the robot {pset.robot!r}; the robot "
            f"here is {self.robot.name!r}: it may walk differently or fall"
        ]

    def start(self) -> None:
        if self.bus_port is not None:
            self.bus_port.start()
            print(f"artro serve: the servo bus is on {self.bus_port.port}", flush=True)
        self.sim.start()
        if self.viewer is not None:
            self.viewer.start()

    def stop(self) -> None:
        self.importer.cancel()  # its child killed: no import outlives the server
        self.replay.leave()
        self.jobs.stop()  # every job (a tune's child too): no simulation outlives us
        if self.viewer is not None:
            self.viewer.stop()
        self.sim.stop()
        if self.bus_port is not None:
            self.bus_port.stop()
