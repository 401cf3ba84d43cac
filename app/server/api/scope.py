"""The TDM-PWM oscilloscope: recent frames over HTTP, live frames over a WebSocket."""

import asyncio
import contextlib
from typing import Annotated, Any

from fastapi import APIRouter, Query, Response, WebSocket, WebSocketDisconnect
from starlette.concurrency import run_in_threadpool

from app.server.api.answers_data import ScopeFrames
from app.server.api.deps import ServicesDep, WsServicesDep
from app.server.feeds.scope_feed import HISTORY_FRAMES
from app.server.http.errors import GATE_RESPONSES, responses

router = APIRouter(tags=["scope"], responses=GATE_RESPONSES)
INLINE_FORMAT_FRAMES = 2  # about 0.3 ms each
FRAMES_RESPONSE: dict[int | str, dict[str, Any]] = {
    200: {
        "description": "the frames, oldest first",
        "content": {
            "application/json": {
                "schema": {
                    "type": "object",
                    "required": ["frames"],
                    "properties": {"frames": {"type": "array", "items": {"type": "object"}}},
                }
            }
        },
    }
}


@router.get("/api/scope", response_model=ScopeFrames, responses=FRAMES_RESPONSE | responses(422))
async def recent_frames(
    services: ServicesDep,
    frames: Annotated[int, Query(ge=1, le=HISTORY_FRAMES, description="how many")] = 1,
) -> Response:
    """The last N TDM-PWM frames: per channel the slots (servo, OCR ticks, pulse us, degrees),
    the edges of the six TDM lines and three select lines, and flags. Each frame is serialised
    once for every client (app/server/feeds/scope_feed.py): with at most a few new frames to format
    this answers on the event loop, else in the thread pool."""
    feed = services.scope
    if feed.unformatted(frames) <= INLINE_FORMAT_FRAMES:
        body = feed.recent_json(frames)
    else:
        body = await run_in_threadpool(feed.recent_json, frames)
    return Response(body, media_type="application/json")


@router.websocket("/ws/scope")
async def live_frames(websocket: WebSocket, services: WsServicesDep) -> None:
    """One JSON message per 20 ms simulated frame. A client that reads too slowly loses frames."""
    await websocket.accept()
    hub = services.scope
    client = hub.connect()
    receiver = asyncio.create_task(_drain(websocket))
    try:
        while not receiver.done():
            getter = asyncio.create_task(client.queue.get())
            done, _ = await asyncio.wait({getter, receiver}, return_when=asyncio.FIRST_COMPLETED)
            if getter not in done:
                getter.cancel()
                break
            await websocket.send_text(getter.result())
    except (WebSocketDisconnect, RuntimeError):
        pass
    finally:
        hub.disconnect(client)
        receiver.cancel()
        with contextlib.suppress(Exception):
            await websocket.close()


async def _drain(websocket: WebSocket) -> None:
    """Read (and ignore) what the client sends, so a disconnect is noticed at once."""
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            await websocket.receive_text()
