"""Running a server command (`serve`, `rosbridge`) until it is stopped (layer 5).

uvicorn with robotrial's settings (`ros.rosbridge.transport.uvicorn_config`); once it has
stopped and the app's shutdown has closed what it opened (recordings, jobs, the live
platform), the process ends at once: the interpreter's own teardown (a final garbage
collection over numba's and MuJoCo's objects) would otherwise take seconds, and SIGTERM
must stop a server within five.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any

from robotrial.console import console


def run_server(app: Any, host: str, port: int, on_stop: Callable[[], None] | None = None) -> None:
    """Serve `app` on host:port until Ctrl+C or SIGTERM, call `on_stop`, then end the
    process (exit code 0, or 128 + the signal's number as a shell reports it)."""
    import signal

    import uvicorn

    from robotrial.ros.rosbridge.transport import uvicorn_config

    server = uvicorn.Server(uvicorn_config(app, host, port))
    code = 0
    try:
        server.run()
    except KeyboardInterrupt as stop:
        code = 128 + (signal.SIGTERM if str(stop).startswith("signal") else signal.SIGINT)
    if not server.started:
        console.print(f"[red]error:[/red] could not listen on {host}:{port} (see above)")
        code = code or 1
    if on_stop is not None:
        on_stop()
    console.file.flush()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
