"""Health, state and simulation control."""

from collections.abc import Callable
from typing import Any, Literal

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from app.firmware.build import BuildError
from app.firmware.emulator import EmulatorError
from app.params.document import project_version
from app.server.api.answers import (
    ANSWER,
    Accepted,
    DriveAccepted,
    Health,
    PushAccepted,
    SpeedAccepted,
    State,
)
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.recording.replay import RUNS_LIVE, Replaying
from app.server.services import Services
from app.server.sim.pacing import SPEED_RANGE
from app.server.sim.sim_commands import (
    PUSH_RANGE_N_S,
    Control,
    DriveRefused,
    Pause,
    Push,
    PushRefused,
    Reset,
    Resume,
    SetSpeed,
    Step,
)

router = APIRouter(tags=["simulation"], responses=GATE_RESPONSES, route_class=StrictJsonRoute)


class SpeedBody(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    speed: float = Field(ge=SPEED_RANGE[0], le=SPEED_RANGE[1], description="x real time")


class DriveBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    drive: Literal["model", "firmware"] = Field(  # app/server/sim/live_robot.py Drive's values
        description="model: the Python hardware model makes the pulses; firmware: the robot's "
        "firmware on an emulated ATmega128 does, and the servos read them off its pins"
    )


@router.get("/api/health", response_model=Health, **ANSWER)
def health(services: ServicesDep) -> dict[str, Any]:
    return {
        "status": "ok" if services.running else "simulation stopped",
        "version": project_version(),
        # the port the 3D view is on: viser takes the next free one when the asked one is taken
        "viser_port": services.viser_port,
    }


@router.get("/api/state", response_model=State, **ANSWER)
def state(services: ServicesDep) -> dict[str, Any]:
    """Sim time, real-time factor, fell, trunk pose, parameter version and more; `tune` and
    `fit` are the latest tune's and fit's id and status (null: none ran), `robustness_report`
    whether a report of the gait in use is kept (`GET /api/world/robustness`) and `servo_bus`
    whether the server runs a bus (`GET /api/bus`), so a page asks for none of them when there
    is none, and a reloaded page follows a job that runs."""
    snap, scope = services.snapshot(), services.scope
    tune, fit = services.tuner.latest, services.fitter.latest
    return services.sim_status().to_dict() | {
        "params_version": snap.version,
        "scope": {"clients": scope.client_count, "dropped": scope.dropped},
        "running": services.running,
        "replay": services.replay_status(),
        "tune": None if tune is None else {"id": tune.id, "status": tune.status},
        "fit": None if fit is None else {"id": fit.id, "status": fit.status},
        "robustness_report": services.robustness.last_report(snap) is not None,
        "servo_bus": services.bus_port is not None,
    }


def _control(command: Control, doc: str) -> Callable[[Services], dict[str, str]]:
    def control(services: ServicesDep) -> dict[str, str]:
        try:
            services.replay.live_command(command)
        except Replaying as exc:
            raise ApiError(409, str(exc), "replaying", loc=["path"]) from exc
        return {"accepted": command.name}

    control.__doc__ = doc
    return control


# one route per action (not /api/sim/{action}): a wrong method gets 405 with its true Allow
for _command, _doc in (
    (Reset(), "Put the robot back at the start; the real-time factor restarts."),
    (Pause(), "Pause the simulation."),
    (Resume(), "Resume the simulation; 409 while a replay is shown (go back to live)."),
    (Step(), "Advance one 20 ms frame (pausing first); 409 while a replay is shown."),
):
    router.add_api_route(
        f"/api/sim/{_command.name}",
        _control(_command, _doc),
        methods=["POST"],
        response_model=Accepted,
        response_model_exclude_unset=True,
        name=f"sim_{_command.name}",
        summary=f"{_command.name.title()}",
        responses=responses(409) if isinstance(_command, RUNS_LIVE) else None,
    )


@router.put("/api/sim/speed", response_model=SpeedAccepted, responses=responses(422), **ANSWER)
def set_speed(body: SpeedBody, services: ServicesDep) -> dict:
    services.send(SetSpeed(body.speed))
    return {"accepted": "speed", "speed": body.speed}


@router.put(
    "/api/sim/drive", response_model=DriveAccepted, responses=responses(409, 422, 503), **ANSWER
)
def set_drive(body: DriveBody, services: ServicesDep) -> dict:
    """Switch who makes the servo pulses. The firmware is built for the current set (seconds on
    a cold cache) and boots at its start phase, so the robot starts over; back to the model, it
    walks on. `GET /api/state` says which drive is on (`drive`, `firmware`)."""
    try:
        services.switch_drive(body.drive)
    except DriveRefused as exc:
        status = 503 if exc.reason == "drive_failed" else 409
        raise ApiError(status, str(exc), exc.reason, loc=["body", "drive"]) from exc
    except ValueError as exc:
        raise ApiError(409, str(exc), "unsupported_engine", loc=["body", "drive"]) from exc
    except (BuildError, EmulatorError) as exc:
        raise ApiError(503, str(exc), "firmware_unavailable", loc=["body", "drive"]) from exc
    except TimeoutError as exc:
        raise ApiError(503, str(exc), "drive_unanswered", loc=["body", "drive"]) from exc
    return {"accepted": "drive", "drive": body.drive}


class PushBody(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    impulse_n_s: float = Field(
        ge=PUSH_RANGE_N_S[0], le=PUSH_RANGE_N_S[1], description="the push's impulse, N·s"
    )
    direction_deg: float = Field(
        default=0.0,
        ge=-360.0,
        le=360.0,
        description="toward where, counter-clockwise from where the robot faces (0 forward, "
        "90 to its left)",
    )


@router.post("/api/sim/push", response_model=PushAccepted, responses=responses(409, 422), **ANSWER)
def push(body: PushBody, services: ServicesDep) -> dict:
    """Push the robot's trunk: the impulse in one physics step, level, in the direction given
    relative to the robot. `GET /api/state` says the last push (`push`), the 3D view draws it;
    409 while a replay is shown, the robot lies fallen, or the pushes waiting for the next
    physics step (sent while paused) would add up past 2 N·s: they act there as one push."""
    if services.replay_status()["active"]:
        raise ApiError(
            409,
            "a replay is shown: go back to live first (POST /api/recording/live)",
            "replaying",
            loc=["path"],
        )
    if services.sim_status().fell:
        raise ApiError(
            409,
            "the robot has fallen and the simulation stopped: reset first (POST /api/sim/reset)",
            "fallen",
            loc=["path"],
        )
    try:
        services.push(Push(body.impulse_n_s, body.direction_deg))
    except PushRefused as exc:
        raise ApiError(409, str(exc), "pushes_pending", loc=["body", "impulse_n_s"]) from exc
    return {
        "accepted": "push",
        "impulse_n_s": body.impulse_n_s,
        "direction_deg": body.direction_deg,
    }
