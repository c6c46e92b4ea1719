"""rosbridge over WebSocket: the route on the web app and the standalone server (layer 4).

`add_rosbridge_route(app, bus)` serves the protocol at `/rosbridge` on a FastAPI app;
`standalone_app(bus)` is an app with only rosbridge (at `/` and `/rosbridge`), which
`serve()` runs with uvicorn, as `robotrial rosbridge --port 9090` does.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import struct
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
    either side closes. A token that matches (`?token=`, a bearer header or the page's
    cookie) lets the client in without `auth`; a foreign Host header is refused."""
    access = server.access
    refusal = access.host_refusal(websocket.headers)
    if refusal is None and not access.origin_allowed(websocket.headers):
        refusal = access.refusal(websocket.headers)
    if refusal is not None:
        log.warning("rosbridge: %s", refusal)
        await websocket.close(code=1008)
        return
    await websocket.accept()

    async def send(frame: str | bytes) -> None:
        if isinstance(frame, str):
            await websocket.send_text(frame)
        else:
            await websocket.send_bytes(frame)

    session = server.open_session(send)
    given = access.request_token(websocket.headers, websocket.query_params, websocket.cookies)
    if access.token is not None and access.token_ok(given):
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
        await _close(websocket, 1000)


CLOSE_WAIT_S = 1.0
"""How long the close frame may wait for a client that stopped reading."""


async def _close_when_ended(session: Session, websocket: WebSocket) -> None:
    await session.ended.wait()
    await _close(websocket, 1008 if session.close_reason else 1011, session.close_reason)


async def _close(websocket: WebSocket, code: int, reason: str = "") -> None:
    """Close the WebSocket with `code` and `reason` (cut to the 123 bytes a close frame
    holds); a client that does not take the close frame in CLOSE_WAIT_S has its TCP
    connection aborted, so a stalled client costs no memory once dropped."""
    if websocket.application_state != WebSocketState.CONNECTED:
        return
    reason = reason.encode()[:123].decode(errors="ignore")
    try:
        await asyncio.wait_for(websocket.close(code=code, reason=reason), CLOSE_WAIT_S)
    except TimeoutError:
        _abort(websocket)
    except Exception:
        log.debug("closing a rosbridge WebSocket failed")


def _abort(websocket: WebSocket) -> None:
    """Drop the connection under `websocket` without a handshake, when the ASGI server
    exposed its transport (`ConnectionHandle`)."""
    transport = websocket.scope.get(TRANSPORT_KEY)
    if transport is None:
        return
    sock = transport.get_extra_info("socket")
    if sock is not None:  # a reset, so the kernel drops what it still holds for the client
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    transport.abort()


TRANSPORT_KEY = "robotrial.transport"


class ConnectionHandle:
    """ASGI middleware that puts each WebSocket's network transport in its scope (at
    TRANSPORT_KEY), where the ASGI server's `send` is a method of an object holding one
    (uvicorn's protocols are): the only way to drop a client that stopped reading, whose
    close frame would wait behind the data it does not take."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] == "websocket":
            transport = getattr(getattr(send, "__self__", None), "transport", None)
            scope = {**scope, TRANSPORT_KEY: transport}
        await self.app(scope, receive, send)


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
    if not getattr(app.state, "rosbridge", None):
        app.add_middleware(ConnectionHandle)
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


SHUTDOWN_GRACE_S = 2.0
"""How long a stopping server waits for open connections before it closes them."""


def uvicorn_config(app: Any, host: str, port: int, **kwargs: Any) -> Any:
    """uvicorn settings for every robotrial server (the web app and rosbridge alone):
    large frames; no per-message compression, as rosbridge_suite's server: deflating a
    point cloud for each client costs the event loop more than the link saves, and a
    compressing client stalls everyone else; a quiet access log; connections closed
    SHUTDOWN_GRACE_S after a stop is asked, so SIGTERM ends the server within seconds."""
    import uvicorn

    return uvicorn.Config(
        app,
        host=host,
        port=port,
        ws_max_size=TRANSPORT_MAX_BYTES,
        ws_per_message_deflate=False,
        log_level=kwargs.pop("log_level", "warning"),
        access_log=False,
        timeout_graceful_shutdown=SHUTDOWN_GRACE_S,
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
