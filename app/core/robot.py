"""The built-in ArtRo MuJoCo model: loading it, and the indices that map the gait onto it.

The simulation, the tests and the viewer all go through `RobotModel`, so joint and site names of
docs/DESIGN.md §3 are looked up in one place.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.assets import model_xml
from gait import JOINT_NAMES, LegGeometry

ARTRO_XML = model_xml()


@dataclass(frozen=True)
class RobotModel:
    """A compiled model plus the addresses of the 12 leg joints in the gait's joint order."""

    model: mujoco.MjModel
    qpos_adr: NDArray[np.int_]  # (12,) qpos index of each joint, JOINT_NAMES order
    dof_adr: NDArray[np.int_]  # (12,) qvel index
    actuator_ids: NDArray[np.int_]  # (12,) actuator index
    trunk_id: int
    gyro_adr: int  # sensordata index of the 3-axis trunk gyro
    sole_adr: tuple[int, int]  # sensordata index of the left and right sole centre positions

    @classmethod
    def load(cls, path: Path | str = ARTRO_XML) -> RobotModel:
        """Compile the MJCF at `path` (default: the built-in model) and look up its joints,
        actuators, trunk and sensors; ValueError or KeyError if one is missing or it fails."""
        model = mujoco.MjModel.from_xml_path(str(path))
        qpos, dof, act = [], [], []
        for name in JOINT_NAMES:
            joint = model.joint(name)
            qpos.append(int(joint.qposadr[0]))
            dof.append(int(joint.dofadr[0]))
            act.append(int(model.actuator(name).id))
        return cls(
            model=model,
            qpos_adr=np.array(qpos),
            dof_adr=np.array(dof),
            actuator_ids=np.array(act),
            trunk_id=int(model.body("trunk").id),
            gyro_adr=_sensor_adr(model, "imu_gyro"),
            sole_adr=(_sensor_adr(model, "l_sole_pos"), _sensor_adr(model, "r_sole_pos")),
        )

    def leg_geometry(self) -> LegGeometry:
        """L_UL and L_LL measured from the model's hip, knee and ankle positions."""
        data = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, data)
        hip = data.site("l_hip").xpos
        knee = data.body("l_shank").xpos
        ankle = data.site("l_ankle").xpos
        return LegGeometry(
            upper_m=float(np.linalg.norm(knee - hip)), lower_m=float(np.linalg.norm(ankle - knee))
        )

    def total_mass_kg(self) -> float:
        """Mass of the whole robot (the trunk body's subtree), kg."""
        return float(self.model.body_subtreemass[self.trunk_id])

    def standing_height_m(self, joint_angles: NDArray[np.float64]) -> float:
        """Trunk height at which the lower sole just touches the floor, for the given pose."""
        data = mujoco.MjData(self.model)
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
