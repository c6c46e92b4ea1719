"""Who may talk to the robot: the Origin and Host checks and the optional token (layer 4).

A browser sends `Origin` with every WebSocket and cross-site POST, so a page from
another site that the user happens to visit could otherwise drive the robot. Accepted
by default: clients that send no Origin (roslibpy, Node tools, ROS bridges) and pages
from the server itself (Origin equal to the Host they connect to, when that Host names
this machine or the address the server listens on, so a DNS name pointed at 127.0.0.1
by another site does not count). `--allow-origin` adds origins (`*`: any).

Every request must name this server in its Host header (`trusted_host`): a page whose
DNS name was pointed at 127.0.0.1 by another site (DNS rebinding) is refused before it
reads anything.

With a token, nothing but the token opens the door: a rosbridge client sends
`{"op": "auth", "mac": TOKEN}` first (or connects with `?token=TOKEN`), any other request
sends `Authorization: Bearer TOKEN` (or `?token=TOKEN`); the page, opened once with
`?token=`, carries it in the TOKEN_COOKIE cookie (HttpOnly, SameSite=Strict).
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit

log = logging.getLogger(__name__)

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
TOKEN_COOKIE = "robotrial_token"


def _host_name(netloc: str) -> str:
    """The host of `host[:port]` (brackets of IPv6 removed), lower case."""
    return (urlsplit(f"//{netloc}").hostname or "").lower()


def _is_loopback(name: str) -> bool:
    if name == "localhost" or name.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def _port(parts) -> int | None:
    try:
        return parts.port or {"http": 80, "https": 443}.get(parts.scheme)
    except ValueError:
        return None


def read_token(text: str | None, file: str | Path | None) -> str | None:
    """The token given on the command line or in a file (first line), or None; a
    ValueError that names the file when it cannot be read or is empty."""
    if text is not None and file is not None:
        raise ValueError("give --token or --token-file, not both")
    if file is not None:
        try:
            text = Path(file).read_text().splitlines()[0] if Path(file).stat().st_size else ""
        except (OSError, IndexError) as exc:
            raise ValueError(f"--token-file {file}: cannot read it ({exc})") from exc
        if not text.strip():
            raise ValueError(f"--token-file {file}: the file is empty")
    if text is None:
        return None
    if len(text.strip()) < 8:
        raise ValueError("the token must have at least 8 characters")
    return text.strip()


@dataclass(frozen=True)
class Access:
    """The rule for one server: the address it listens on, extra allowed origins, the
    token (None: no token needed)."""

    listen_host: str = "127.0.0.1"
    allowed_origins: tuple[str, ...] = ()
    token: str | None = None

    @staticmethod
    def create(
        listen_host: str = "127.0.0.1",
        allow_origins: Iterable[str] = (),
        token: str | None = None,
    ) -> Access:
        origins = tuple(o.strip().rstrip("/").lower() for o in allow_origins if o.strip())
        if "*" in origins:
            log.warning("--allow-origin '*': pages from any web site may drive this robot")
        return Access(listen_host, origins, token)

    def trusted_host(self, host: str) -> bool:
        """Whether a Host header names this server: a loopback name, or anything when the
        server listens on every interface or on a named address."""
        if _is_loopback(_host_name(host)):
            return True
        return not _is_loopback(self.listen_host.strip("[]").lower())

    def origin_allowed(self, headers: Mapping[str, str]) -> bool:
        """Whether a request with these headers comes from a client allowed in."""
        origin = headers.get("origin")
        if origin is None or "*" in self.allowed_origins:
            return True
        origin = origin.strip().rstrip("/").lower()
        if origin in self.allowed_origins:
            return True
        host = headers.get("host", "").lower()
        page, target = urlsplit(origin), urlsplit(f"//{host}")
        if page.scheme not in ("http", "https") or not self.trusted_host(host):
            return False
        if page.netloc == host:
            return True
        # localhost and 127.0.0.1 name the same machine: the same server on the same port
        both_here = _is_loopback(page.hostname or "") and _is_loopback(target.hostname or "")
        return both_here and _port(page) == _port(target)

    def token_ok(self, given: str | None) -> bool:
        """Whether `given` is the token (always, when there is none)."""
        if self.token is None:
            return True
        return given is not None and hmac.compare_digest(given.encode(), self.token.encode())

    def request_token(
        self,
        headers: Mapping[str, str],
        query: Mapping[str, str],
        cookies: Mapping[str, str] | None = None,
    ) -> str | None:
        """The token a request carries: `Authorization: Bearer ...`, `?token=` or the
        page's cookie."""
        auth = headers.get("authorization", "")
        if auth.lower().startswith("bearer "):
            return auth[7:].strip()
        return query.get("token") or (cookies or {}).get(TOKEN_COOKIE)

    def host_refusal(self, headers: Mapping[str, str]) -> str | None:
        """Why a request's Host header is refused, or None when it names this server."""
        host = headers.get("host", "")
        if self.trusted_host(host):
            return None
        return (
            f"Host {host[:60]!r} is not this server's name; it answers on localhost and "
            f"127.0.0.1 (start it with --host to listen on a network address)"
        )

    def refusal(self, headers: Mapping[str, str]) -> str:
        origin = headers.get("origin", "")
        return (
            f"connections from {origin} are not allowed; start the server with "
            f"--allow-origin {origin} to allow that site"
        )
