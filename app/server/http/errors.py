"""One error shape for every refusal of the API (docs/DESIGN.md §6):
`{"detail": [{"loc": [...], "msg": "...", "type": "..."}], "message": "...", "version": n|null}`.

Nothing the client sent is echoed beyond a few hundred bytes: locations and messages are capped.
"""

from __future__ import annotations

import errno
import logging
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field
from pydantic.errors import PydanticUserError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match, Mount

from app.server.http.body_rules import allowed_at, body_schema

log = logging.getLogger(__name__)

MAX_ITEMS = 10
#: the errors of a disk with no room left: the device is full, or the user's quota is
NO_SPACE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})
NO_SPACE = (
    "no space left on the device where the server keeps its data: nothing was written; free "
    "some space there (or start the server with another --data-dir), then try again"
)
#: a pattern of a path or query parameter -> the rule in words, said instead of the regex
PATTERN_RULES: dict[str, str] = {}
MAX_TEXT = 300
MAX_LOC_PART = 64


class ErrorItem(BaseModel):
    loc: list[str | int] = Field(description="where: 'body', then field names; or 'header', ...")
    msg: str = Field(description="what was wrong and what is allowed")
    type: str = Field(description="a machine-readable kind, e.g. 'version_conflict'")


class ErrorBody(BaseModel):
    detail: list[ErrorItem]
    message: str = Field(description="the items in one readable line")
    version: int | None = Field(
        None, description="the parameter version in use now (on 409/412 conflicts)"
    )


class ApiError(Exception):
    """Raise from a route: answered with `status` and the one error shape."""

    def __init__(
        self,
        status: int,
        msg: str,
        type: str,
        *,
        loc: Sequence[str | int] = (),
        headers: Mapping[str, str] | None = None,
        version: int | None = None,
        items: Sequence[Mapping[str, Any]] = (),
    ) -> None:
        """`items`: several problems ({loc, msg, type}); by default the one of msg, type, loc."""
        super().__init__(msg)
        self.status, self.msg, self.type, self.loc = status, msg, type, list(loc)
        self.headers, self.version = dict(headers or {}), version
        self.items = list(items) or [{"loc": self.loc, "msg": msg, "type": type}]


def _cap(text: str, limit: int = MAX_TEXT) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _loc_part(part: Any) -> str | int:
    return part if isinstance(part, int) and not isinstance(part, bool) else _cap(str(part), 64)


def error_content(
    items: Iterable[Mapping[str, Any]], version: int | None = None, total: int | None = None
) -> dict[str, Any]:
    detail = [
        {
            "loc": [_loc_part(p) for p in list(item.get("loc", ()))[:8]],
            "msg": _cap(str(item.get("msg", ""))),
            "type": _cap(str(item.get("type", "error")), MAX_LOC_PART),
        }
        for item in list(items)[:MAX_ITEMS]
    ]
    parts = [
        f"{'.'.join(str(p) for p in d['loc'] if p != 'body')}: {d['msg']}".removeprefix(": ")
        for d in detail
    ]
    more = f"; and {total - len(detail)} more" if total is not None and total > len(detail) else ""
    message = _cap("; ".join(parts), 2 * MAX_TEXT - len(more)) + more  # the count is never cut
    return {"detail": detail, "message": message.removeprefix("; "), "version": version}


def error_response(
    status: int,
    msg: str,
    type: str,
    *,
    loc: Sequence[str | int] = (),
    headers: Mapping[str, str] | None = None,
    version: int | None = None,
) -> JSONResponse:
    content = error_content([{"loc": loc, "msg": msg, "type": type}], version)
    return JSONResponse(content, status_code=status, headers=dict(headers or {}))


_HTTP_TYPES = {
    400: "bad_request",
    403: "forbidden",
    404: "not_found",
    405: "method_not_allowed",
    409: "conflict",
    412: "precondition_failed",
    413: "body_too_large",
    415: "unsupported_media_type",
}


METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE")


def allowed_methods(app: Any, scope: Mapping[str, Any]) -> list[str]:
    """Every method some route answers at this path (the true `Allow` of a 405). A path of its
    own (`/api/presets/diff`) shadows a template (`/api/presets/{name}`): only its methods count;
    the template's routes refuse that name with a 405."""
    routes = list(_flat_routes(app.routes))
    literal: set[str] = set()
    templated: set[str] = set()
    for method in METHODS:
        for route in routes:
            match, child = route.matches({**scope, "method": method, "path_params": {}})
            if match is Match.FULL:
                (templated if child.get("path_params") else literal).add(method)
    found = literal or templated
    return [m for m in METHODS if m in found]


def _flat_routes(routes: Iterable[Any]) -> Iterable[Any]:
    """The routes of the app and of the routers it includes (FastAPI keeps those nested)."""
    for route in routes:
        included = getattr(route, "original_router", None)
        if included is not None:
            yield from _flat_routes(included.routes)
        elif not isinstance(route, Mount):
            yield route


def install_handlers(app: FastAPI) -> None:
    @app.exception_handler(ApiError)
    async def api_error(_request: Request, exc: ApiError) -> JSONResponse:
        content = error_content(exc.items, exc.version, total=len(exc.items))
        return JSONResponse(content, status_code=exc.status, headers=exc.headers)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        headers = dict(exc.headers or {})
        msg = exc.detail if isinstance(exc.detail, str) else str(exc.detail)
        if exc.status_code == 405:
            allow = allowed_methods(request.app, request.scope)
            headers["Allow"] = ", ".join(allow)
            msg = f"{request.method} is not allowed here; allowed: {', '.join(allow)}"
        elif exc.status_code == 404:
            msg = f"nothing at {_cap(request.url.path, 100)}"
        kind = _HTTP_TYPES.get(exc.status_code, "http_error")
        return error_response(exc.status_code, msg, kind, headers=headers)

    @app.exception_handler(RequestValidationError)
    async def invalid_request(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = exc.errors()
        items = []
        for e in errors[:MAX_ITEMS]:
            msg, loc = e.get("msg", ""), e.get("loc", ())
            if e.get("type") == "json_invalid":  # the strict parser says where; no offset 0
                loc = ("body",)
                if (e.get("ctx") or {}).get("error"):
                    msg = f"{msg}: {e['ctx']['error']}"
            rule = PATTERN_RULES.get((e.get("ctx") or {}).get("pattern", ""))
            if e.get("type") == "string_pattern_mismatch" and rule:
                msg = f"{rule}; got {e.get('input')!r}"
            elif e.get("type") != "json_invalid" and "allowed" not in msg:
                msg += _allowed_in_body(request, loc, e.get("type", ""))
            items.append({"loc": loc, "msg": msg, "type": e.get("type", "invalid")})
        return JSONResponse(status_code=422, content=error_content(items, total=len(errors)))

    @app.exception_handler(ValueError)
    async def value_error(_request: Request, exc: ValueError) -> JSONResponse:
        return error_response(422, str(exc), "value_error", loc=["body"])

    @app.exception_handler(OSError)
    async def os_error(request: Request, exc: OSError) -> JSONResponse:
        """A full disk is no fault of the server's: 507 in words and one line in the log, the
        connection kept (a 500 carried a traceback into the log and reset the connection).
        Any other OSError is unexpected (below)."""
        if exc.errno not in NO_SPACE_ERRNOS:
            raise exc
        where = f" ({exc.filename})" if exc.filename else ""
        log.error("%s %s: no space left on the device%s", request.method, request.url.path, where)
        return error_response(507, NO_SPACE, "no_space")

    @app.exception_handler(Exception)
    async def unexpected(_request: Request, exc: Exception) -> JSONResponse:
        """A fault of the server's, never of the request: the one shape, a 500, and the server
        carries on (the traceback goes to the log)."""
        msg = f"the server failed on this request ({type(exc).__name__}); it carries on"
        return error_response(500, msg, "internal_error")


def _allowed_in_body(request: Request, loc: Sequence[Any], kind: str) -> str:
    """ "; allowed: ..." for an error in the route's body, from its schema ("" elsewhere or
    where the schema does not say); an unknown field gets what its object allows."""
    field = getattr(request.scope.get("route"), "body_field", None)
    if field is None or not loc or loc[0] != "body":
        return ""
    where = list(loc[1:-1] if kind == "extra_forbidden" else loc[1:])
    try:
        allowed = allowed_at(body_schema(field.field_info.annotation), where)
    except (PydanticUserError, TypeError, ValueError):  # no schema: pydantic's message alone
        return ""
    return f"; allowed: {allowed}" if allowed else ""


def responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI `responses=` entries with the error shape for these statuses."""
    text = {
        400: "Host not served (DNS rebinding protection) or a body that could not be read",
        403: "a cross-site request or WebSocket (Origin / Sec-Fetch-Site)",
        404: "no such resource",
        405: "method not allowed; `Allow` lists the allowed ones",
        409: "conflict: a stale `version`, or nothing to undo/redo, or a job already running, "
        "or a parameter set the firmware cannot run",
        412: "`If-Match` names a version that is no longer current",
        413: "the request body is too large",
        415: "a body that is not JSON (or YAML where declared)",
        422: "invalid input; nothing changed",
        429: "another recording is being imported: try again when it is done (`Retry-After`)",
        503: "the firmware tool chain (avr-gcc) or the emulator (simavr) is not available",
        507: "no space left on the device where the server keeps its data; nothing was written",
    }
    return {s: {"model": ErrorBody, "description": text[s]} for s in statuses}


#: What any route may answer because of the request gate (app/server/http/request_gate.py).
GATE_RESPONSES = responses(400, 403, 413, 415)
