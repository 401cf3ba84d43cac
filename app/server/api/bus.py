"""The servo bus route: `artro serve --servo-bus pty`'s port and traffic (docs/BUS.md)."""

from dataclasses import asdict
from typing import Any

from fastapi import APIRouter

from app.server.api.answers import ANSWER
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.sim.bus_port import BusPortStatus

router = APIRouter(
    prefix="/api/bus", tags=["bus"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)


@router.get("", response_model=BusPortStatus, responses=responses(404), **ANSWER)
def bus_status(services: ServicesDep) -> dict[str, Any]:
    """The virtual servo bus of `artro serve --servo-bus pty`: its port (a pseudo-terminal's
    path), protocol, baud and servo IDs; whether it drives the robot (a goal write within the
    last second); packets (total, per second over the last second), errors (malformed packets
    by reason), packets to no servo, answers and how late the latest went out (µs), goal writes
    and their latency to the frame that took them (ms). 404 when the server runs no bus."""
    port = services.bus_port
    if port is None:
        raise ApiError(404, "no servo bus: start the server with --servo-bus pty", "no_bus")
    return asdict(port.status())
