"""`robotrial bench service`: the web server under a hostile load (layer 5).

`robotrial serve` runs in its own process with the live platform (default: the mobile
manipulator in room A). For `--seconds`, `--clients` WebSocket clients that offer
permessage-deflate (as browsers and Python's `websockets` do) subscribe to `/points`
and read everything, and `--stalled` clients subscribe and then never read a byte.
Meanwhile, once a second, a probe times `GET /api/config` and a PlanTask call for the
desk arm over rosbridge. The figures: latency of both (median, p99, max), timeouts, the
server's resident memory after the first 10 s (first, last, highest), and whether the
stalled clients were dropped.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import contextlib
import json
import os
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.benchmarks.planning import DESK_REQUEST
from robotrial.benchmarks.rosbridge import free_port, server_process
from robotrial.console import add_json_flag, print_json, print_table, progress, write_result
from robotrial.ros.planning_node import robot_service

HELP = "the server under load: /points to compressing and stalled clients, page and plan timed"
PROBE_TIMEOUT_S = 30.0
PLAN_SERVICE = robot_service("desk_arm")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seconds", type=float, default=60.0, help="length of the load")
    parser.add_argument("--clients", type=int, default=3, help="compressing /points readers")
    parser.add_argument("--stalled", type=int, default=1, help="/points clients that never read")
    parser.add_argument("--robot", default="mobile_manipulator", help="the server's robot")
    parser.add_argument("--world", default="room_a", help="the server's world")
    parser.add_argument(
        "--server-arg",
        action="append",
        default=[],
        metavar="ARG",
        help="an extra argument for `robotrial serve` (repeatable)",
    )
    parser.add_argument("-o", "--output", type=Path, default=None, help="write the JSON here")
    parser.add_argument("--plot", type=Path, default=None, help="latency and memory over time")
    add_json_flag(parser)


def _rss_mb(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def _subscribe_op(topic: str, sid: str) -> str:
    return json.dumps({"op": "subscribe", "id": sid, "topic": topic})


async def _reader(url: str, i: int, stop: asyncio.Event, counts: list[int]) -> None:
    """A client that offers permessage-deflate and reads every frame of /points."""
    import websockets

    with contextlib.suppress(Exception):
        async with websockets.connect(
            url, max_size=None, compression="deflate", ping_interval=None
        ) as ws:
            await ws.send(_subscribe_op("/points", f"reader{i}"))
            while not stop.is_set():
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(ws.recv(), 1.0)
                    counts[i] += 1


def _stalled_client(port: int, path: str) -> socket.socket:
    """A raw WebSocket that asks for deflate, subscribes to /points and never reads."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n"
            "Sec-WebSocket-Extensions: permessage-deflate; client_max_window_bits\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = sock.recv(1)
        if not chunk:
            raise RuntimeError("the server closed the stalled client's handshake")
        head += chunk
    payload = _subscribe_op("/points", "stalled").encode()
    mask = os.urandom(4)
    masked = bytes(b ^ mask[j % 4] for j, b in enumerate(payload))
    sock.sendall(bytes([0x81, 0x80 | 126]) + struct.pack("!H", len(payload)) + mask + masked)
    sock.setblocking(False)
    return sock


def _dropped(sock: socket.socket) -> bool:
    """Whether the server has closed this never-reading client (its reads end in EOF or
    a reset once the buffered frames are drained)."""
    try:
        while True:
            data = sock.recv(1 << 20)
            if not data:
                return True
    except BlockingIOError:
        return False
    except OSError:
        return True


async def _probe_config(client: Any, url: str) -> float:
    t0 = time.perf_counter()
    try:
        r = await client.get(url, timeout=PROBE_TIMEOUT_S)
        r.raise_for_status()
    except Exception:
        return float("inf")
    return time.perf_counter() - t0


async def _probe_plan(ws: Any, n: int) -> tuple[float, bool]:
    op = {"op": "call_service", "id": f"plan{n}", "service": PLAN_SERVICE, "args": DESK_REQUEST}
    t0 = time.perf_counter()
    await ws.send(json.dumps(op))
    try:
        while True:
            msg = json.loads(await asyncio.wait_for(ws.recv(), PROBE_TIMEOUT_S))
            if msg.get("op") == "service_response" and msg.get("id") == f"plan{n}":
                ok = bool(msg.get("result")) and bool(msg["values"].get("success"))
                return time.perf_counter() - t0, ok
    except TimeoutError:
        return float("inf"), False


async def _wait_ready(client: Any, base: str, proc: subprocess.Popen) -> None:
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"robotrial serve exited with code {proc.returncode}")
        with contextlib.suppress(Exception):
            r = await client.get(base + "/api/config", timeout=2.0)
            cfg = r.json()
            if cfg.get("planner") in (None, "ready"):
                return
        await asyncio.sleep(0.5)
    raise RuntimeError("the server was not ready within 120 s")


async def _measure(args: argparse.Namespace, port: int, proc: subprocess.Popen) -> dict:
    import httpx
    import websockets

    base = f"http://127.0.0.1:{port}"
    ws_url = f"ws://127.0.0.1:{port}/rosbridge"
    async with httpx.AsyncClient() as client:
        await _wait_ready(client, base, proc)
        async with websockets.connect(
            ws_url, max_size=None, compression=None, ping_interval=None
        ) as planner:
            await _probe_plan(planner, -1)  # the first plan builds the arm's planner
            stop = asyncio.Event()
            counts = [0] * args.clients
            readers = [
                asyncio.ensure_future(_reader(ws_url, i, stop, counts)) for i in range(args.clients)
            ]
            waited = time.monotonic()
            while min(counts, default=1) == 0:  # the live platform is still starting
                if time.monotonic() - waited > 180.0:
                    raise RuntimeError("no /points message reached the readers within 180 s")
                await asyncio.sleep(0.2)
            stalled = [_stalled_client(port, "/rosbridge") for _ in range(args.stalled)]
            dropped_at: list[float | None] = [None] * len(stalled)
            rows: list[dict[str, float]] = []
            t_start = time.perf_counter()
            with progress("load", args.seconds, enabled=not args.json) as advance:
                n = 0
                shown = 0.0
                while (t := time.perf_counter() - t_start) < args.seconds:
                    config_s = await _probe_config(client, base + "/api/config")
                    plan_s, ok = await _probe_plan(planner, n)
                    rows.append(
                        {
                            "t": t,
                            "config_s": config_s,
                            "plan_s": plan_s,
                            "plan_ok": float(ok),
                            "rss_mb": _rss_mb(proc.pid) or float("nan"),
                        }
                    )
                    for k, sock in enumerate(stalled):
                        if dropped_at[k] is None and _dropped(sock):
                            dropped_at[k] = t
                    n += 1
                    advance(min(t, args.seconds) - shown)
                    shown = min(t, args.seconds)
                    await asyncio.sleep(max(0.0, 1.0 - (time.perf_counter() - t_start - t)))
            stop.set()
            await asyncio.gather(*readers, return_exceptions=True)
            for sock in stalled:
                sock.close()
    return {"rows": rows, "frames": counts, "dropped_at": dropped_at}


def _stats(values: np.ndarray) -> dict[str, float]:
    done = values[np.isfinite(values)]
    if done.size == 0:
        return {"median_ms": float("nan"), "p99_ms": float("nan"), "max_ms": float("nan")}
    return {
        "median_ms": float(np.median(done) * 1e3),
        "p99_ms": float(np.percentile(done, 99) * 1e3),
        "max_ms": float(done.max() * 1e3),
    }


def summarize(measured: dict, args: argparse.Namespace) -> dict[str, Any]:
    """The figures of one run: latencies, timeouts, memory after 10 s, drops."""
    rows = measured["rows"]
    config = np.array([r["config_s"] for r in rows])
    plan = np.array([r["plan_s"] for r in rows])
    t = np.array([r["t"] for r in rows])
    rss = np.array([r["rss_mb"] for r in rows])
    late = rss[t >= 10.0]
    return {
        "seconds": args.seconds,
        "clients": args.clients,
        "stalled": args.stalled,
        "probes": len(rows),
        "config": {**_stats(config), "timeouts": int(np.sum(~np.isfinite(config)))},
        "plan_task": {
            **_stats(plan),
            "timeouts": int(np.sum(~np.isfinite(plan))),
            "failed": int(sum(1 for r in rows if not r["plan_ok"])),
        },
        "rss_mb": {
            "at_10s": float(late[0]) if late.size else float("nan"),
            "last": float(rss[-1]) if rss.size else float("nan"),
            "max_after_10s": float(late.max()) if late.size else float("nan"),
        },
        "frames_per_reader": measured["frames"],
        "stalled_dropped_at_s": measured["dropped_at"],
    }


def _plot(measured: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = measured["rows"]
    t = [r["t"] for r in rows]
    fig, (a, b) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for key, label in (("config_s", "GET /api/config"), ("plan_s", "PlanTask")):
        a.plot(t, [min(r[key], PROBE_TIMEOUT_S) * 1e3 for r in rows], ".-", label=label)
    a.set_yscale("log")
    a.set_ylabel("latency (ms)")
    a.legend()
    b.plot(t, [r["rss_mb"] for r in rows], "-")
    b.set_ylabel("server memory (MB)")
    b.set_xlabel("time under load (s)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    port = free_port()
    cmd = [sys.executable, "-c", "import robotrial.cli as c; raise SystemExit(c.main())"]
    cmd += ["serve", "--port", str(port)]
    cmd += ["--robot", args.robot, "--world", args.world, "--foxglove-port", "0"]
    cmd += args.server_arg
    with server_process(cmd, port, timeout=120.0) as proc:
        measured = asyncio.run(_measure(args, port, proc))
    result = summarize(measured, args)
    write_result({**result, "rows": measured["rows"]}, args.output)
    if args.plot is not None:
        _plot(measured, args.plot)
    if args.json:
        print_json(result)
        return 0
    rows = []
    for name in ("config", "plan_task"):
        s = result[name]
        ms = [f"{s[k]:.1f}" for k in ("median_ms", "p99_ms", "max_ms")]
        rows.append([name, *ms, str(s["timeouts"])])
    print_table(
        "the server under load", ["probe", "median ms", "p99 ms", "max ms", "timeouts"], rows
    )
    m = result["rss_mb"]
    print(
        f"server memory: {m['at_10s']:.0f} MB at 10 s, {m['last']:.0f} MB at the end, "
        f"{m['max_after_10s']:.0f} MB at most after 10 s; frames per reader "
        f"{result['frames_per_reader']}; stalled clients dropped at "
        f"{result['stalled_dropped_at_s']} s"
    )
    return 0
