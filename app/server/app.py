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
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.staticfiles import StaticFiles

from app.assets import static_dir
from app.params.document import project_version
from app.server.api import params, paths, presets, scope, servos, sim
from app.server.services import ServerConfig, Services

VENDOR = "/vendor"  # third-party files served with the page (static/vendor/)
FAVICON = "data:image/svg+xml,%3Csvg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 16 16'%3E%3Cpath d='M1 12h3V4h4v8h3V4h4' fill='none' stroke='%23f2d04b' stroke-width='2'/%3E%3C/svg%3E"  # noqa: E501


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
        docs_url=None,  # served below from the page's own files: /docs works offline
        redoc_url=None,
    )

    @app.get("/docs", include_in_schema=False)
    async def docs() -> HTMLResponse:
        """Swagger UI from static/vendor/swagger-ui (no CDN)."""
        return get_swagger_ui_html(
            openapi_url=app.openapi_url or "/openapi.json",
            title=f"{app.title} — API",
            swagger_js_url=f"{VENDOR}/swagger-ui/swagger-ui-bundle.js",
            swagger_css_url=f"{VENDOR}/swagger-ui/swagger-ui.css",
            swagger_favicon_url=FAVICON,
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

    routers = (sim.router, params.router, scope.router, paths.router, presets.router, servos.router)
    for router in routers:
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
