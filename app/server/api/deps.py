"""Dependencies and the route class shared by the routers.

`StrictJsonRoute` parses every JSON body with the project's one rule (duplicate keys and
NaN/Infinity refused, naming the key: `app.params.strict_text.load_json_strict`), off the event loop
when the body is not tiny (docs/DESIGN.md §6)."""

import json
from collections.abc import Callable, Coroutine
from typing import Annotated, Any

from annotated_types import Ge
from fastapi import Depends, Request, Response, WebSocket
from fastapi.routing import APIRoute
from pydantic import BeforeValidator
from starlette.concurrency import run_in_threadpool

from app.params.strict_text import ParameterImportError, load_json_strict
from app.server.services import Services


def _whole_float_to_int(value: Any) -> Any:
    return int(value) if isinstance(value, float) and value.is_integer() else value


#: an integer as JSON has it, after its minimum (`Annotated[int, Ge(n), WHOLE_FLOAT]`): JSON
#: Schema's integer includes 3.0, so a whole float is taken; strings and booleans stay refused
#: (strict)
WHOLE_FLOAT = BeforeValidator(_whole_float_to_int)
JsonIntFrom0 = Annotated[int, Ge(0), WHOLE_FLOAT]  # an integer >= 0 as JSON has it
JsonIntFrom1 = Annotated[int, Ge(1), WHOLE_FLOAT]  # an integer >= 1 as JSON has it


INLINE_PARSE_BYTES = 2048  # smaller bodies parse in microseconds: not worth a thread hop


def get_services(request: Request) -> Services:
    return request.app.state.services


def get_ws_services(websocket: WebSocket) -> Services:
    return websocket.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]
WsServicesDep = Annotated[Services, Depends(get_ws_services)]


def _parse(body: bytes) -> Any:
    try:
        return load_json_strict(body)
    except ParameterImportError as exc:  # FastAPI answers JSONDecodeError with a 422
        raise json.JSONDecodeError(str(exc), "", 0) from exc


class StrictJsonRequest(Request):
    async def json(self) -> Any:
        if not hasattr(self, "_json"):
            body = await self.body()
            if len(body) <= INLINE_PARSE_BYTES:
                self._json = _parse(body)
            else:
                self._json = await run_in_threadpool(_parse, body)
        return self._json


class StrictJsonRoute(APIRoute):
    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def strict_handler(request: Request) -> Response:
            return await handler(StrictJsonRequest(request.scope, request.receive))

        return strict_handler
