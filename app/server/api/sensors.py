"""The Sensors panel's route: what the modelled IMU and force sensors read over the last seconds
and what the feedback laws made of it (docs/DESIGN.md §15)."""

from typing import Any

from fastapi import APIRouter

from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.errors import GATE_RESPONSES
from app.server.sensor_trace import COLUMNS

router = APIRouter(
    prefix="/api/sensors", tags=["sensors"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


@router.get("")
def sensors(services: ServicesDep) -> dict[str, Any]:
    """The last 5 s, one value per 20 ms frame in each column (oldest first; null where a sole
    carries nothing): the estimated attitude against the simulator's true one (for the eye
    only, no law reads it), the gyro, each law's output, each sole's centre of pressure (mm
    from its centre, x forward, y left) and load; with the sole outline and the force sensors'
    places. Empty columns before the first frame."""
    view = services.sim.sensor_view()
    if view is None:
        return {"columns": {name: [] for name in COLUMNS}, "sole_mm": None, "fsr_mm": []}
    return view.to_dict()
