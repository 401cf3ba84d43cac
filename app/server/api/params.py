"""The parameter set: read, replace, patch, undo, redo; and the schema it follows.

Optimistic concurrency (docs/DESIGN.md §6): GET gives the version, also as ETag; a change naming
a stale one in the body (409) or in If-Match (412) changes nothing. Undo/redo say whose change
they reverted."""

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Header, Response

from app.params.document import ParameterSet
from app.params.schema import ParamsBody, ParamsPatchBody, schema_description
from app.server.api.answers import ANSWER, Params, SchemaGroup
from app.server.api.deps import ServicesDep, StrictJsonRoute
from app.server.http.errors import GATE_RESPONSES, ApiError, responses
from app.server.param_store import Check, NothingToUndo, RobotBusy, Snapshot
from app.server.services import Services

router = APIRouter(
    prefix="/api", tags=["parameters"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)

IfMatch = Annotated[
    str | None,
    Header(
        max_length=200,
        description='change only if the current version is this ETag (e.g. "12"); '
        "otherwise 412 with the current version",
    ),
]
GESTURE_PATTERN = r"^[A-Za-z0-9_.:-]{1,64}$"
Gesture = Annotated[
    str | None,
    Header(
        alias="Artro-Gesture",
        max_length=64,
        pattern=GESTURE_PATTERN,
        description="the user's gesture this change belongs to (1-64 letters, digits, _ . : -), "
        "e.g. one drag of a slider: while the version in use was made by the same gesture, the "
        "change is a new version but no new undo step",
    ),
]
ETAG_HEADER = {"ETag": {"description": 'the version, e.g. "12"', "schema": {"type": "string"}}}


def etag(snapshot: Snapshot) -> str:
    return f'"{snapshot.version}"'


def _tagged(response: Response, snapshot: Snapshot) -> dict[str, Any]:
    response.headers["ETag"] = etag(snapshot)
    return snapshot.to_dict()


def versions_check(body_version: int | None, if_match: str | None) -> Check:
    """Refuse (409 body version / 412 If-Match) unless the current version is the named one."""

    def check(current: Snapshot) -> None:
        if if_match is not None:
            tags = {t.strip().removeprefix("W/") for t in if_match.split(",")}
            if "*" not in tags and etag(current) not in tags:
                raise ApiError(
                    412,
                    f"If-Match {if_match[:60]!r} is not the current version {etag(current)}; "
                    "GET /api/params and try again",
                    "precondition_failed",
                    loc=["header", "if-match"],
                    version=current.version,
                )
        if body_version is not None and body_version != current.version:
            raise ApiError(
                409,
                f"version {body_version} is not the current version {current.version} (changed "
                f"by {current.source}); GET /api/params and try again",
                "version_conflict",
                loc=["body", "version"],
                version=current.version,
            )

    return check


@router.get("/params", response_model=Params, responses={200: {"headers": ETAG_HEADER}}, **ANSWER)
def get_params(services: ServicesDep, response: Response) -> dict[str, Any]:
    """The parameters in use, with their version (also the `ETag`)."""
    return _tagged(response, services.snapshot())


@router.put(
    "/params",
    response_model=Params,
    responses=responses(409, 412, 422) | {200: {"headers": ETAG_HEADER}},
    **ANSWER,
)
def put_params(
    body: ParamsBody, services: ServicesDep, response: Response, if_match: IfMatch = None
) -> dict[str, Any]:
    """Replace every parameter; invalid input or a stale version changes nothing. A set that
    names the robot it was tuned for, another than the one in use, is loaded with `warnings`
    saying so (the robot in use stays)."""
    store = services.store
    name = body.name or store.snapshot().name
    doc = {"name": name, "motion": body.motion.model_dump(), "gait": body.gait.model_dump()}
    pset = ParameterSet.from_dict(doc | ({"robot": body.robot} if body.robot else {}))
    warnings = services.robot_warnings(pset) if body.robot else []
    check = versions_check(body.version, if_match)
    if body.name is None:  # keep the name in use at the moment of the change
        snapshot = store.update(pset_patch(pset), "http", check=check)
    else:
        snapshot = store.replace(pset, "http", check=check)
    return _tagged(response, snapshot) | {"warnings": warnings}


def pset_patch(pset: ParameterSet) -> dict[str, Any]:
    return {"motion": pset.to_dict()["motion"], "gait": pset.gait.to_dict()}


@router.patch(
    "/params",
    response_model=Params,
    responses=responses(409, 412, 422) | {200: {"headers": ETAG_HEADER}},
    **ANSWER,
)
def patch_params(
    body: ParamsPatchBody,
    services: ServicesDep,
    response: Response,
    if_match: IfMatch = None,
    gesture: Gesture = None,
) -> dict[str, Any]:
    """Change some parameters; the rest stay. Invalid input or a stale version changes nothing.
    With `Artro-Gesture`, the changes of one gesture (a slider drag) are one undo step."""
    check = versions_check(body.version, if_match)
    snapshot = services.store.update(body.as_patch(), "http", check=check, gesture=gesture)
    return _tagged(response, snapshot)


@router.post("/params/undo", response_model=Params, responses=responses(409, 412, 422), **ANSWER)
def undo(services: ServicesDep, response: Response, if_match: IfMatch = None) -> dict[str, Any]:
    """Undo the latest change of the one shared history, whoever made it (see redo)."""
    return _history("undo", services, response, if_match)


@router.post("/params/redo", response_model=Params, responses=responses(409, 412, 422), **ANSWER)
def redo(services: ServicesDep, response: Response, if_match: IfMatch = None) -> dict[str, Any]:
    """Redo the latest undone change. Undo and redo act on the one shared history; `reverted`
    says whose change (version, source) was replaced. To undo only your own latest change, send
    `If-Match` with the version it gave you (412 if someone changed something since).
    409 when there is nothing to undo or redo."""
    return _history("redo", services, response, if_match)


def _history(
    step: Literal["undo", "redo"], services: Services, response: Response, if_match: str | None
) -> dict[str, Any]:
    replaced: list[Snapshot] = []
    check_versions = versions_check(None, if_match)

    def check(current: Snapshot) -> None:
        check_versions(current)
        replaced.append(current)

    move = services.store.undo if step == "undo" else services.store.redo
    try:
        snapshot = move("http", check=check)
    except NothingToUndo as exc:
        current = services.snapshot()
        raise ApiError(409, str(exc), "nothing_to_" + step, version=current.version) from exc
    except RobotBusy as exc:  # the step would change robots while something runs on this one
        current = services.snapshot()
        raise ApiError(409, str(exc), "robot_busy", version=current.version) from exc
    reverted = {"version": replaced[0].version, "source": replaced[0].source}
    return _tagged(response, snapshot) | {"reverted": reverted}


@router.get("/schema", response_model=list[SchemaGroup], **ANSWER)
def schema() -> list[dict[str, Any]]:
    """Every parameter group and field: label, default, range, step, unit, equation, meaning."""
    return schema_description()
