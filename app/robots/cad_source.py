"""The `cad:` section of a robot description imported from a URDF or MJCF file (`artro robot
import`, docs/DESIGN.md §16): which file, how its root turns into the trunk's frame, which of its
joints is which gait joint with its sign and zero offset, the feet's soles and what is held
rigid. The model is built from the file with these (`app.robots.cad_builder`); the import finds
them (`app.robots.cad_mapping`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, Strict

Real = Annotated[float, Strict()]
Name = Annotated[str, Strict(), Field(min_length=1, max_length=200)]
Point = tuple[Real, Real, Real]
Quat = tuple[Real, Real, Real, Real]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class CadJoint(_Strict):
    """A gait joint in the file: paper angle = sign × (file angle − its ref) + zero_rad."""

    file_joint: Name
    sign: Literal[1, -1]
    zero_rad: Real = Field(ge=-3.2, le=3.2, description="the paper angle of the file's zero pose")
    axis_error_deg: Real = Field(0.0, ge=0, le=90, description="the axis from the ideal")


class CadFoot(_Strict):
    """A foot: its body in the file, the sole's centre and axes in that body, its plate."""

    body: Name
    sole_pos_m: Point
    sole_quat: Quat
    plate_geom: Name | None = Field(
        None, description="the file's box that is the sole; none: added"
    )


class CadSite(_Strict):
    body: Name
    pos_m: Point


class CadSource(_Strict):
    """Where an imported robot's model comes from and how it maps onto the gait."""

    file: Name = Field(description="the URDF or MJCF file, relative to the description's folder")
    format: Literal["urdf", "mjcf"]
    package_dirs: tuple[Name, ...] = Field((), description="where package:// mesh paths resolve")
    root_body: Name
    trunk_quat: Quat = Field(description="the root body's frame in the trunk's (x fwd, z up)")
    forward_from: Literal["toes", "knees", "given"] = "toes"
    joints: dict[str, CadJoint]
    feet: dict[Literal["l", "r"], CadFoot]
    sites: dict[str, CadSite] = Field(description="l_hip, l_ankle, r_hip, r_ankle")
    held: tuple[Name, ...] = Field((), description="the file's joints that are no leg's: rigid")
    keep_actuators: bool = Field(
        False, description="the file's position actuators as they are, not the servo table's"
    )
    imu_site: Name | None = Field(None, description="a site of the file for the IMU")


def resolved(cad: CadSource | None, folder: Path) -> CadSource | None:
    """`cad` with its file taken from `folder` when relative: a description read from a file
    names its CAD file relative to itself."""
    if cad is None or Path(cad.file).is_absolute():
        return cad
    return cad.model_copy(update={"file": str((folder / cad.file).resolve())})
