"""A robot's MuJoCo model, built from its description, and the indices that map the gait onto it:
joint and site names of docs/DESIGN.md §3 are looked up in one place, and the leg geometry and the
servo set-up (calibration, TDM map) come from the same description (docs/DESIGN.md §7)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots import RobotDescription, build_model, joint_settings, load_description
from app.robots.cad_import import mapping_rows
from app.robots.checks import eq1_torques, robot_warnings
from app.robots.model_parts import FSR_CORNERS
from gait import JOINT_NAMES, LegGeometry
from hardware import ChannelMap, HardwareSetup, ServoCalibration, TdmConfig
from hardware.servo_bus import BusLink


@dataclass(frozen=True)
class RobotModel:
    """A compiled model of a described robot plus the addresses of the 12 leg joints in the
    gait's joint order."""

    description: RobotDescription
    model: mujoco.MjModel
    qpos_adr: NDArray[np.int_]  # (12,) qpos index of each joint, JOINT_NAMES order
    dof_adr: NDArray[np.int_]  # (12,) qvel index
    actuator_ids: NDArray[np.int_]  # (12,) actuator index
    trunk_id: int
    gyro_adr: int  # sensordata index of the 3-axis trunk gyro
    sole_adr: tuple[int, int]  # sensordata index of the left and right sole centre positions
    accel_adr: int  # sensordata index of the 3-axis trunk accelerometer
    fsr_sites: NDArray[np.int_]  # (2, 4) site id of each foot force sensor's zone (FSR_CORNERS)
    foot_ids: tuple[int, int]  # body id of the left and right foot
    torque_adr: NDArray[np.int_]  # (12,) sensordata index of each servo's torque, JOINT_NAMES order

    @classmethod
    def load(cls, robot: str | Path | RobotDescription | None = None) -> RobotModel:
        """Build the model of `robot`: a built-in name (default `artro`), a description file or a
        description (`app.robots.load_description`); RobotError if it is not a valid robot."""
        description = load_description(robot)
        return cls.of_model(description, build_model(description))

    @classmethod
    def of_model(cls, description: RobotDescription, model: mujoco.MjModel) -> RobotModel:
        """`model` as the model of `description` (e.g. the built model edited as MJCF by an
        experiment); KeyError if a joint, actuator, body or sensor of docs/DESIGN.md §3 is
        missing."""
        qpos, dof, act = [], [], []
        for name in JOINT_NAMES:
            joint = model.joint(name)
            qpos.append(int(joint.qposadr[0]))
            dof.append(int(joint.dofadr[0]))
            act.append(int(model.actuator(name).id))
        return cls(
            description=description,
            model=model,
            qpos_adr=np.array(qpos),
            dof_adr=np.array(dof),
            actuator_ids=np.array(act),
            trunk_id=int(model.body("trunk").id),
            gyro_adr=_sensor_adr(model, "imu_gyro"),
            sole_adr=(_sensor_adr(model, "l_sole_pos"), _sensor_adr(model, "r_sole_pos")),
            accel_adr=_sensor_adr(model, "imu_accel"),
            fsr_sites=np.array(
                [[int(model.site(f"{s}_fsr_{c}").id) for c in FSR_CORNERS] for s in ("l", "r")]
            ),
            foot_ids=(int(model.site("l_sole").bodyid[0]), int(model.site("r_sole").bodyid[0])),
            torque_adr=np.array([_sensor_adr(model, f"{name}_torque") for name in JOINT_NAMES]),
        )

    @property
    def name(self) -> str:
        return self.description.name

    @property
    def fsr_positions_m(self) -> NDArray[np.float64]:
        """(4, 2) x, y of each force sensor's centre on its sole (`FSR_CORNERS` order), m, in
        the foot's axes from the sole centre (x forward, y left; the right foot as built)."""
        geo = self.description.geometry
        signs = np.array(list(FSR_CORNERS.values()), dtype=np.float64)
        return signs * (geo.foot_length_m / 4, geo.foot_width_m / 4)

    @property
    def geometry(self) -> LegGeometry:
        """L_UL and L_LL of the description: the gait's inverse kinematics (eqs 3–6)."""
        geo = self.description.geometry
        return LegGeometry(upper_m=geo.thigh_m, lower_m=geo.shank_m)

    def hardware(self) -> HardwareSetup:
        """The servo set-up of the description: each joint's calibration and the TDM map (built
        once per model: it is frozen, and the batch evaluator plans every run with it)."""
        return self._hardware

    @cached_property
    def _hardware(self) -> HardwareSetup:
        joints = [self.description.joints[name] for name in JOINT_NAMES]
        limits = [j.calibration.angle_limits_rad() for j in joints]
        calibration = ServoCalibration(
            direction=np.array([j.calibration.direction for j in joints], dtype=np.int64),
            trim_us=np.array([j.calibration.trim_us for j in joints], dtype=np.float64),
            min_rad=np.array([lo for lo, _ in limits], dtype=np.float64),
            max_rad=np.array([hi for _, hi in limits], dtype=np.float64),
        )
        channels = ChannelMap(assignments=self.description.channel_assignments())
        return HardwareSetup(
            calibration=calibration, tdm=TdmConfig(channel_map=channels), bus=self.bus()
        )

    def bus(self) -> BusLink | None:
        """The serial bus of a robot whose 12 servos are all bus servos of one protocol
        (ROBOTIS: Dynamixel 2.0, Feetech: STS); None: TDM-PWM (docs/BUS.md)."""
        makers = {self.description.joint_servo_spec(n).maker for n in JOINT_NAMES}
        signals = {self.description.joint_servo_spec(n).signal for n in JOINT_NAMES}
        protocol = {"ROBOTIS": "dynamixel", "Feetech": "feetech"}.get(next(iter(makers)))
        if signals != {"bus"} or len(makers) != 1 or protocol is None:
            return None
        return BusLink(protocol=protocol, ids=tuple(self.description.bus_ids()))

    def summary(self) -> dict[str, Any]:
        """The description and the figures that follow from it (`artro robot show`,
        `GET /api/robot`): masses, leg, each joint's servo settings, eq (1) per joint."""
        desc = self.description
        torques = eq1_torques(desc)  # once: the figures and the warnings
        return {
            "name": desc.name,
            "title": desc.title,
            "default_preset": desc.default_preset,
            "description": desc.model_dump(mode="json"),
            "geometry": desc.geometry.model_dump(mode="json"),
            "total_mass_kg": self.total_mass_kg(),
            "mapping": {
                joint.pop("joint"): joint for joint in mapping_rows(desc)
            },  # an imported robot's: gait joint -> file joint, sign, zero, axis error
            "derived": {
                "total_mass_kg": self.total_mass_kg(),
                "link_masses_kg": desc.link_masses_kg(),
                "leg": {"upper_m": self.geometry.upper_m, "lower_m": self.geometry.lower_m},
                "standing_height_m": desc.geometry.standing_height_m,
                "servos": {k: v.to_dict() for k, v in joint_settings(desc).items()},
                "eq1": [t.to_dict() for t in torques],
                "warnings": robot_warnings(desc, torques=torques),
            },
        }

    def measured_leg_geometry(self) -> LegGeometry:
        """L_UL and L_LL measured from the model's hip, knee and ankle positions (a check of
        the builder against `geometry`)."""
        data = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, data)
        hip = data.site("l_hip").xpos
        knee = data.body("l_shank").xpos
        ankle = data.site("l_ankle").xpos
        return LegGeometry(
            upper_m=float(np.linalg.norm(knee - hip)), lower_m=float(np.linalg.norm(ankle - knee))
        )

    def leg_axes(self) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """Each leg joint's anchor and axis (world, m), standing straight at the origin, with
        the positive direction of its paper angle (`artro robot show --png`)."""
        data = mujoco.MjData(self.model)
        data.qpos[self.qpos_adr] = 0.0
        data.qpos[:3] = (0.0, 0.0, self.standing_height_m(np.zeros(12)))
        data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        mujoco.mj_kinematics(self.model, data)
        return {
            name: (data.xanchor[j].copy(), data.xaxis[j].copy())
            for name in JOINT_NAMES
            for j in [self.model.joint(name).id]
        }

    def total_mass_kg(self) -> float:
        """Mass of the whole robot (the trunk body's subtree), kg."""
        return float(self.model.body_subtreemass[self.trunk_id])

    def standing_height_m(
        self, joint_angles: NDArray[np.float64], scratch: mujoco.MjData | None = None
    ) -> float:
        """Trunk height at which the lower sole just touches the floor, for the given pose;
        `scratch` (reset here, left in that pose) spares making an MjData."""
        data = mujoco.MjData(self.model) if scratch is None else scratch
        if scratch is not None:
            mujoco.mj_resetData(self.model, data)
        data.qpos[self.qpos_adr] = joint_angles
        data.qpos[2] = 0.0
        data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        mujoco.mj_kinematics(self.model, data)
        lowest = min(lowest_sole_z(data, side) for side in ("l", "r"))
        return -lowest


def _sensor_adr(model: mujoco.MjModel, name: str) -> int:
    return int(model.sensor(name).adr[0])


def lowest_sole_z(data: mujoco.MjData, side: str) -> float:
    """Lowest z of the four bottom corners of a foot plate."""
    geom = data.geom(f"{side}_foot_plate")
    half = data.model.geom(f"{side}_foot_plate").size
    corners = np.array([[sx * half[0], sy * half[1], -half[2]] for sx in (-1, 1) for sy in (-1, 1)])
    world = geom.xpos + corners @ geom.xmat.reshape(3, 3).T
    return float(world[:, 2].min())
