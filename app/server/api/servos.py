"""The servo load budget route: torque and speed against each servo, eq (1) (docs/DESIGN.md §5)."""

from dataclasses import asdict
from typing import Any

from fastapi import APIRouter

from app.server.api.answers import ANSWER
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES
from app.sim.servo_load import ServoLoadReport

router = APIRouter(
    prefix="/api/servos", tags=["servos"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


@router.get("/load", response_model=ServoLoadReport, **ANSWER)
def servo_load(services: ServicesDep) -> dict[str, Any]:
    """Per joint since the last reset or parameter change, sampled once per 20 ms frame: peak
    and RMS torque against the stall torque, eq (1)'s required torque (1 + sf) peak |tau| and its
    margin, peak speed against the no-load speed, frames with a saturated pulse, and a level
    (ok, warn below 30 % margin, critical below 10 %); each joint's servo, whether it meets
    eq (1) (`eq1_met`) and, where it does not, the lightest servo of the table (or the robot's
    file) that would at the robot's supply (`eq1_servo`: name, stall torque, mass)."""
    return asdict(services.servo_load())
