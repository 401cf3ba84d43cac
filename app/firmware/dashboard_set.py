"""The dashboard's parameter set as `artro link` takes it (docs/DESIGN.md §15): a GET /api/params
answer checked to be a dashboard's set, its plain document for the schema, and the refusal of a
set made for another robot than the firmware's."""

from __future__ import annotations

from typing import Any

from app.firmware.protocol import LinkError
from app.params.document import DEFAULT_ROBOT, ParameterSet

JSON_KINDS = {list: "list", str: "string", int: "number", float: "number", bool: "boolean",
              type(None): "null"}  # fmt: skip
DASHBOARD_SET = (
    "a parameter set as an ArtRo dashboard's GET /api/params returns it (a JSON object with "
    "version, motion and gait)"
)


def other_robot(doc: dict[str, Any], server: str, firmware_robot: str) -> None:
    """LinkError, naming both robots, if the dashboard's set `doc` is for another robot than
    the firmware on the port (a set is tuned for one robot's legs and servos: `PUT
    /api/params` warns of it, a robot would walk it as it may, or fall)."""
    robot = doc.get("robot") or DEFAULT_ROBOT
    if robot == firmware_robot:
        return
    raise LinkError(
        f"the dashboard at {server} simulates the robot {robot!r}, and its set "
        f"{doc.get('name') or 'dashboard'!r} (version {doc['version']}) is for it; the firmware "
        f"on the port is built for {firmware_robot!r} (--robot): nothing sent. Switch the "
        f"dashboard to {firmware_robot!r}, or give --robot {robot} if the firmware was built "
        "for it"
    )


def dashboard_set(response: Any, server: str) -> dict[str, Any]:
    """The JSON object of a GET /api/params answer; LinkError naming the server and what came
    if it is not a dashboard's parameter set."""
    try:
        doc = response.json()
    except ValueError:
        kind = response.headers.get("content-type") or "no content type"
        what = f"{kind}, not JSON ({response.text[:40]!r})"
    else:
        if not isinstance(doc, dict):
            what = f"a JSON {JSON_KINDS.get(type(doc), type(doc).__name__)}"
        else:
            missing = [key for key in ("version", "motion", "gait") if key not in doc]
            if not missing:
                return doc
            what = f"a JSON object without {', '.join(missing)}"
    raise LinkError(
        f"the server at {server} is not an ArtRo dashboard: GET /api/params gave {what}; "
        f"expected {DASHBOARD_SET}"
    )


def plain_set(doc: dict[str, Any], server: str | None = None) -> dict[str, Any]:
    """The parameter-set document of an API answer (validated by the schema; LinkError naming
    the `server` if the schema refuses it)."""
    try:
        pset = ParameterSet.from_dict({"motion": doc["motion"], "gait": doc["gait"]})
    except ValueError as exc:
        at = "" if server is None else f" at {server}"
        raise LinkError(
            f"the server{at} gave a parameter set this studio cannot take ({exc}); "
            f"expected {DASHBOARD_SET}"
        ) from exc
    return pset.to_dict() | {"name": doc.get("name") or "dashboard"}
