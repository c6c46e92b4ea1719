"""Who may read and write on the web server (layer 5): an ASGI middleware in front of
every route.

- Every request, HTTP or WebSocket, must name this server in its Host header
  (`Access.host_refusal`), so a page served under another site's DNS name that resolves
  to this machine (DNS rebinding) reads nothing.
- With a token, every route but the page shell (`/` and its scripts and styles under
  `/assets/`) needs it: `Authorization: Bearer TOKEN`, `?token=TOKEN`, or the cookie the
  page shell sets when it is opened with `?token=`. The rosbridge WebSocket checks the
  token itself (rosbridge's `auth` operation is the protocol's way to send it).
"""

from __future__ import annotations

import json
from typing import Any

from starlette.datastructures import Headers, QueryParams
from starlette.requests import cookie_parser

from robotrial.ros.rosbridge.access import Access

PAGE_SHELL = ("/", "/favicon.ico")
PAGE_ASSETS = "/assets/"
MISSING_TOKEN = (
    "this server needs its token: open the address `robotrial serve` printed (it ends in "
    "?token=...), or send Authorization: Bearer TOKEN"
)


class AccessGuard:
    """Refuses requests with a foreign Host (400) or without the token (401); lets the
    rest through to `app`. `rosbridge_path`: the WebSocket that checks the token itself."""

    def __init__(self, app: Any, access: Access, rosbridge_path: str | None) -> None:
        self.app = app
        self.access = access
        self.rosbridge_path = rosbridge_path

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        refusal = self.access.host_refusal(headers)
        if refusal is not None:
            await _refuse(scope, send, 400, refusal)
            return
        if self.access.token is not None and not self._open(scope):
            query = QueryParams(scope.get("query_string", b""))
            cookies = cookie_parser(headers.get("cookie", ""))
            if not self.access.token_ok(self.access.request_token(headers, query, cookies)):
                await _refuse(scope, send, 401, MISSING_TOKEN)
                return
        await self.app(scope, receive, send)

    def _open(self, scope: dict) -> bool:
        """Whether a request reaches its route without the token."""
        path = scope["path"]
        if scope["type"] == "websocket":
            return path == self.rosbridge_path
        return path in PAGE_SHELL or path.startswith(PAGE_ASSETS)


async def _refuse(scope: dict, send: Any, status: int, detail: str) -> None:
    """Answer with `status` and a JSON body {"detail": ...}; a WebSocket is refused
    before its handshake (the client sees the HTTP status)."""
    body = json.dumps({"detail": detail}).encode()
    if scope["type"] == "websocket":
        if "websocket.http.response" not in scope.get("extensions", {}):
            await send({"type": "websocket.close", "code": 1008, "reason": detail[:120]})
            return
        await send(
            {
                "type": "websocket.http.response.start",
                "status": status,
                "headers": [(b"content-type", b"application/json")],
            }
        )
        await send({"type": "websocket.http.response.body", "body": body})
        return
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
