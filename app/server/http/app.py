"""The FastAPI application of `artro serve`: REST + WebSocket API and the static page.

`create_app()` builds the app; its lifespan starts and stops what the app owns (the simulation
thread and the viser view, through `Services`). Routers live in `app/server/api/`, one per resource.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from starlette.routing import Match, Mount
from starlette.types import Scope

from app.assets import static_dir
from app.params.document import project_version
from app.server.api import (
    bus,
    fit,
    ghost,
    jobs,
    params,
    paths,
    presets,
    recording,
    robot,
    scope,
    sensors,
    servos,
    sim,
    tune,
    world,
)
from app.server.http.errors import install_handlers
from app.server.http.http_protocol import HeadDeadlineProtocol
from app.server.http.request_gate import GATED_PREFIXES, RequestGate, served_hosts
from app.server.services import ServerConfig, Services

VENDOR = "/vendor"  # third-party files served with the page (static/vendor/)
FAVICON = "data:image/svg+xml,%3Csvg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 16 16'%3E%3Cpath d='M1 12h3V4h4v8h3V4h4' fill='none' stroke='%23f2d04b' stroke-width='2'/%3E%3C/svg%3E"  # noqa: E501


#: how uvicorn serves the app (`artro serve`, the tests' servers): a WebSocket client only
#: listens, so a message larger than 64 KiB closes its socket; a stop waits at most 5 s for
#: requests in flight (a client holding a body half sent held the server, its simulation and
#: a tune's child process after SIGTERM for as long as it liked); a request's head must come
#: whole within HEAD_TIMEOUT_S (HeadDeadlineProtocol)
UVICORN_OPTIONS = {
    "ws_max_size": 65536,
    "timeout_graceful_shutdown": 5,
    "http": HeadDeadlineProtocol,
}


def create_app(config: ServerConfig | None = None) -> FastAPI:
    config = config or ServerConfig()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        services = Services(config)
        services.scope.attach_loop(asyncio.get_running_loop())
        services.start()
        app.state.services = services
        try:
            yield
        except asyncio.CancelledError:
            # a second Ctrl-C: uvicorn skips the lifespan's end and the loop's close cancels it;
            # the services stop all the same, without uvicorn's traceback of the cancellation
            pass
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

    install_handlers(app)
    resources = (sim, params, scope, paths, presets, servos, sensors, world, tune, fit, jobs)
    for resource in (*resources, ghost, bus, recording, robot):
        app.include_router(resource.router)
    # the page is served under every path but the API's: a wrong method or path under /api/
    # gets the API's 405/404, never the static files' answer
    app.router.routes.append(_PageMount(StaticFiles(directory=static_dir(), html=True)))
    app.add_middleware(RequestGate, hosts=served_hosts(config.host, config.allowed_hosts))
    return app


class _PageMount(Mount):
    """The static page at `/`, except under the API prefixes."""

    def __init__(self, app: StaticFiles) -> None:
        super().__init__("/", app=app, name="static")

    def matches(self, scope: Scope) -> tuple[Match, Scope]:
        if scope["path"].startswith(GATED_PREFIXES) or scope["path"] == "/api":
            return Match.NONE, {}
        return super().matches(scope)
