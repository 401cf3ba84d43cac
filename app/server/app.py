"""The FastAPI application of `artro serve`: REST + WebSocket API and the static page.

`create_app()` builds the app; its lifespan starts and stops what the app owns (the simulation
thread and the viser view, through `Services`). Routers live in `app/server/api/`, one per resource.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles

from app.assets import static_dir
from app.params.document import project_version
from app.server.api import params, paths, presets, scope, sim
from app.server.services import ServerConfig, Services


def create_app(config: ServerConfig | None = None) -> FastAPI:
    config = config or ServerConfig()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        services = Services(config)
        services.sim.scope.attach_loop(asyncio.get_running_loop())
        services.start()
        app.state.services = services
        try:
            yield
        finally:
            services.stop()

    app = FastAPI(
        title="ArtRo Gait Studio",
        version=project_version(),
        description="Tune the ArtRo biped's gait in a real-time MuJoCo simulation.",
        lifespan=lifespan,
    )

    @app.exception_handler(RequestValidationError)
    async def invalid_request(_request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [
            {
                "loc": list(e.get("loc", ())),
                "msg": e.get("msg", ""),
                "input": _json_safe(e.get("input")),
            }
            for e in exc.errors()
        ]
        summary = "; ".join(
            f"{'.'.join(str(p) for p in e['loc'] if p != 'body')}: {e['msg']}" for e in errors
        )
        return JSONResponse(status_code=422, content={"detail": errors, "message": summary})

    @app.exception_handler(ValueError)
    async def value_error(_request: Request, exc: ValueError) -> JSONResponse:
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    for router in (sim.router, params.router, scope.router, paths.router, presets.router):
        app.include_router(router)
    app.mount("/", StaticFiles(directory=static_dir(), html=True), name="static")
    return app


def _json_safe(value: Any) -> Any:
    """Echo a rejected input back without breaking JSON (NaN, inf, bytes, odd types)."""
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return repr(value)[:200]
