"""Dependencies shared by the routers."""

from typing import Annotated

from fastapi import Depends, Request, WebSocket

from app.server.services import Services


def get_services(request: Request) -> Services:
    return request.app.state.services


def get_ws_services(websocket: WebSocket) -> Services:
    return websocket.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]
WsServicesDep = Annotated[Services, Depends(get_ws_services)]
