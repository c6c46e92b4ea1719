"""rosbridge over WebSocket: the route on the web app and the standalone server (layer 4).

`add_rosbridge_route(app, bus)` serves the protocol at `/rosbridge` on a FastAPI app;
`standalone_app(bus)` is an app with only rosbridge (at `/` and `/rosbridge`), which
`serve()` runs with uvicorn, as `robotrial rosbridge --port 9090` does.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from fastapi import FastAPI, WebSocket
from starlette.websockets import WebSocketDisconnect, WebSocketState

from robotrial.msgs import Dialect
from robotrial.ros.bus import Bus
from robotrial.ros.rosbridge.access import Access
from robotrial.ros.rosbridge.protocol import Limits, RosbridgeServer, Session

log = logging.getLogger(__name__)

# Frames above the protocol's limit still reach the session (which answers with a status
# error); only frames above this transport limit close the connection.
TRANSPORT_MAX_BYTES = 64 * 2**20


async def run_session(server: RosbridgeServer, websocket: WebSocket) -> None:
    """Accept one WebSocket (if its Origin is allowed) and speak rosbridge on it until
    either side closes. A `?token=` that matches lets the client in without `auth`."""
    access = server.access
    if not access.origin_allowed(websocket.headers):
        log.warning("rosbridge: %s", access.refusal(websocket.headers))
        await websocket.close(code=1008)
        return
    await websocket.accept()

    async def send(frame: str | bytes) -> None:
        if isinstance(frame, str):
            await websocket.send_text(frame)
        else:
            await websocket.send_bytes(frame)

    session = server.open_session(send)
    if access.token is not None and access.token_ok(websocket.query_params.get("token")):
        session.authenticated = True
    # A session can end on its own (its writer failed); then the socket is closed too, so
    # the client sees the disconnect and can reconnect.
    watcher = asyncio.ensure_future(_close_when_ended(session, websocket))
    try:
        while True:
            message = await websocket.receive()
            if message["type"] == "websocket.disconnect":
                break
            data = message.get("text")
            if data is None:
                data = message.get("bytes")
            if data is not None:
                await session.receive(data)
    except (WebSocketDisconnect, RuntimeError, asyncio.CancelledError):
        pass
    finally:
        watcher.cancel()
        await session.close()
        if websocket.application_state == WebSocketState.CONNECTED:
            try:
                await websocket.close()
            except Exception:
                log.debug("closing the WebSocket of %s failed", session.name)


async def _close_when_ended(session: Session, websocket: WebSocket) -> None:
    await session.ended.wait()
    if websocket.application_state == WebSocketState.CONNECTED:
        try:
            await websocket.close(code=1011)
        except Exception:
            log.debug("closing the WebSocket of %s failed", session.name)


def add_rosbridge_route(
    app: FastAPI,
    bus: Bus,
    path: str = "/rosbridge",
    *,
    server: RosbridgeServer | None = None,
    dialect: Dialect = "ros2",
    limits: Limits | None = None,
    access: Access | None = None,
) -> RosbridgeServer:
    """Serve rosbridge v2 for `bus` at `path` on `app`; returns the server object
    (reuse it to add more paths). `access`: who may connect (default: no Origin or the
    server's own, no token)."""
    if server is None:
        server = RosbridgeServer(bus, dialect=dialect, limits=limits, access=access)

    async def rosbridge(websocket: WebSocket) -> None:
        await run_session(server, websocket)

    app.add_api_websocket_route(path, rosbridge, name=f"rosbridge{path.replace('/', '_')}")
    app.state.rosbridge = server
    return server


def standalone_app(
    bus: Bus,
    *,
    dialect: Dialect = "ros2",
    limits: Limits | None = None,
    access: Access | None = None,
) -> FastAPI:
    """An app with rosbridge only, at `/` (where roslibpy and Foxglove connect by
    default) and at `/rosbridge` (as on the web app)."""
    app = FastAPI(title="robotrial rosbridge", docs_url=None, redoc_url=None, openapi_url=None)
    server = add_rosbridge_route(app, bus, "/", dialect=dialect, limits=limits, access=access)
    add_rosbridge_route(app, bus, "/rosbridge", server=server)
    return app


def uvicorn_config(app: Any, host: str, port: int, **kwargs: Any) -> Any:
    """uvicorn settings for rosbridge: large frames, no per-message compression (it costs
    more than it saves for small messages on a LAN), quiet access log."""
    import uvicorn

    return uvicorn.Config(
        app,
        host=host,
        port=port,
        ws_max_size=TRANSPORT_MAX_BYTES,
        ws_per_message_deflate=False,
        log_level=kwargs.pop("log_level", "warning"),
        access_log=False,
        **kwargs,
    )


def serve(
    host: str = "127.0.0.1",
    port: int = 9090,
    bus: Bus | None = None,
    *,
    dialect: Dialect = "ros2",
    access: Access | None = None,
) -> None:
    """Run a standalone rosbridge server until interrupted."""
    import uvicorn

    app = standalone_app(bus or Bus(), dialect=dialect, access=access or Access(host))
    uvicorn.Server(uvicorn_config(app, host, port)).run()
