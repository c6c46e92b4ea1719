"""`robotrial bench rosbridge`: service round trip and /joint_states fan-out (layer 5).

The server runs in its own process (as in use: clients are other programs), started from
this module with an echo service on its bus. Clients are WebSocket connections in this
process speaking plain rosbridge JSON, so the same measurement runs against any
rosbridge server:

- round trip of `call_service` (median, p99) to a service on the bus answered inline,
  one answered in a worker thread (the default for node services), and one offered by
  another rosbridge client (`advertise_service`);
- fan-out: one client publishes sensor_msgs/JointState on /joint_states at 100 Hz, and
  1, 10 and 50 clients subscribe with `queue_length` 1: messages lost and latency.

The baseline is `rosbridge-server-rs` (PyPI) when its binary runs here; otherwise the
report says why it does not.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.console import add_json_flag, print_json, print_table, progress, write_result

HELP = "rosbridge: service round trip and /joint_states fan-out to 1, 10, 50 clients"
RATE_HZ = 100.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--calls", type=int, default=2000, help="service calls per measurement")
    parser.add_argument("--seconds", type=float, default=3.0, help="fan-out time per client count")
    parser.add_argument("--clients", default="1,10,50", help="subscriber counts, comma-separated")
    parser.add_argument("--queue-length", type=int, default=1, help="subscribers' queue_length")
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        help="write the results as JSON here",
    )
    parser.add_argument(
        "--rs-binary",
        default=None,
        help="rosbridge-server-rs executable to compare against (default: search PATH)",
    )
    add_json_flag(parser)


# ---------------------------------------------------------------- the server under test


def serve_for_bench(port: int) -> None:
    """The robotrial server with the benchmark's echo services (run in a subprocess)."""
    import uvicorn

    from robotrial.msgs.std_srvs import SetBool
    from robotrial.ros.bus import Bus
    from robotrial.ros.rosbridge.transport import standalone_app, uvicorn_config

    bus = Bus()

    def echo(req: Any) -> Any:
        return SetBool.Response(success=req.data, message="echo")

    bus.advertise_service("/bench/echo", SetBool, echo, threaded=False)
    bus.advertise_service("/bench/echo_threaded", SetBool, echo)
    uvicorn.Server(uvicorn_config(standalone_app(bus), "127.0.0.1", port)).run()


def free_port() -> int:
    """A TCP port on the loopback that nothing listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_port(port: int, proc: subprocess.Popen, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            err = proc.stderr.read().decode(errors="replace").strip() if proc.stderr else ""
            tail = err.splitlines()[-1] if err else ""
            raise RuntimeError(f"the server exited with code {proc.returncode}: {tail}")
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.2):
            return
        time.sleep(0.05)
    raise RuntimeError(f"the server did not listen on port {port} within {timeout} s")


@contextlib.contextmanager
def server_process(cmd: list[str], port: int, env: dict | None = None, timeout: float = 20.0):
    """A server started by `cmd`, once it listens on `port`; stopped (terminated, then
    killed) on leaving."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    try:
        _wait_port(port, proc, timeout)
        yield proc
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


# ---------------------------------------------------------------- measurements


async def _recv_op(ws: Any, op: str, timeout: float = 10.0) -> dict:
    while True:
        msg = json.loads(await asyncio.wait_for(ws.recv(), timeout))
        if msg.get("op") == op:
            return msg


async def _round_trips(url: str, service: str, calls: int) -> np.ndarray:
    import websockets

    times = []
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for i in range(calls + calls // 10):
            op = {"op": "call_service", "id": f"c{i}", "service": service, "args": {"data": True}}
            t0 = time.perf_counter()
            await ws.send(json.dumps(op))
            resp = await _recv_op(ws, "service_response")
            dt = time.perf_counter() - t0
            if not resp.get("result"):
                raise RuntimeError(f"{service} failed: {resp.get('values')}")
            if i >= calls // 10:  # the first tenth warms up
                times.append(dt)
    return np.array(times)


async def _client_service_round_trips(url: str, calls: int) -> np.ndarray:
    import websockets

    async with websockets.connect(url, max_size=None, compression=None) as provider:
        await provider.send(
            json.dumps(
                {
                    "op": "advertise_service",
                    "service": "/bench/client_echo",
                    "type": "std_srvs/srv/SetBool",
                }
            )
        )

        async def answer() -> None:
            async for raw in provider:
                req = json.loads(raw)
                if req.get("op") == "call_service":
                    await provider.send(
                        json.dumps(
                            {
                                "op": "service_response",
                                "id": req["id"],
                                "service": req["service"],
                                "values": {"success": True, "message": "echo"},
                                "result": True,
                            }
                        )
                    )

        task = asyncio.create_task(answer())
        await asyncio.sleep(0.3)
        try:
            return await _round_trips(url, "/bench/client_echo", calls)
        finally:
            task.cancel()


SUBSCRIBERS_PER_PROCESS = 10


def subscriber_worker(url: str, n: int, total: int, queue_length: int) -> None:
    """`n` subscribers to /joint_states in this process (run as a subprocess): prints
    "ready" once subscribed, then one JSON line with what each received."""
    asyncio.run(_subscribers(url, n, total, queue_length))


async def _subscribers(url: str, n: int, total: int, queue_length: int) -> None:
    import websockets

    received: list[list[int]] = [[] for _ in range(n)]
    latencies: list[float] = []
    subs = [await websockets.connect(url, max_size=None, compression=None) for _ in range(n)]
    for i, ws in enumerate(subs):
        await ws.send(
            json.dumps(
                {
                    "op": "subscribe",
                    "id": f"s{i}",
                    "topic": "/joint_states",
                    "type": "sensor_msgs/msg/JointState",
                    "queue_length": queue_length,
                }
            )
        )
    await asyncio.sleep(0.3)
    print("ready", flush=True)

    async def listen(i: int, ws: Any) -> None:
        with contextlib.suppress(TimeoutError, asyncio.CancelledError):
            timeout = 30.0  # until the first message: the publisher may start late
            while len(received[i]) < total:
                msg = json.loads(await asyncio.wait_for(ws.recv(), timeout))
                timeout = 2.0
                if msg.get("op") != "publish":
                    continue
                now = time.time_ns()
                stamp = msg["msg"]["header"]["stamp"]
                latencies.append((now - (stamp["sec"] * 10**9 + stamp["nanosec"])) * 1e-9)
                received[i].append(int(msg["msg"]["position"][0]))

    await asyncio.gather(*(listen(i, ws) for i, ws in enumerate(subs)))
    for ws in subs:
        with contextlib.suppress(Exception):
            await ws.close()
    print(json.dumps({"received": [len(r) for r in received], "latencies": latencies}), flush=True)


async def _fan_out(url: str, n: int, seconds: float, queue_length: int) -> dict[str, Any]:
    """n subscribers spread over processes of SUBSCRIBERS_PER_PROCESS connections, so the
    clients' own decoding does not stand in for the server's speed."""
    import websockets

    total = int(seconds * RATE_HZ)
    sizes = [SUBSCRIBERS_PER_PROCESS] * (n // SUBSCRIBERS_PER_PROCESS)
    if n % SUBSCRIBERS_PER_PROCESS:
        sizes.append(n % SUBSCRIBERS_PER_PROCESS)
    workers = []
    for size in sizes:
        code = (
            "from robotrial.benchmarks.rosbridge import subscriber_worker; "
            f"subscriber_worker({url!r}, {size}, {total}, {queue_length})"
        )
        workers.append(
            await asyncio.create_subprocess_exec(
                sys.executable, "-c", code, stdout=asyncio.subprocess.PIPE
            )
        )
    try:
        for w in workers:
            line = await asyncio.wait_for(w.stdout.readline(), 60)  # type: ignore[union-attr]
            if line.strip() != b"ready":
                raise RuntimeError(f"a subscriber process failed to start: {line!r}")
        pub = await websockets.connect(url, max_size=None, compression=None)
        await pub.send(
            json.dumps(
                {"op": "advertise", "topic": "/joint_states", "type": "sensor_msgs/msg/JointState"}
            )
        )
        await asyncio.sleep(0.2)
        names = [f"joint_{k}" for k in range(6)]
        t0 = time.perf_counter()
        for k in range(total):
            ns = time.time_ns()
            msg = {
                "header": {"stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}, "frame_id": ""},
                "name": names,
                "position": [float(k)] + [0.1] * 5,
                "velocity": [0.0] * 6,
                "effort": [0.0] * 6,
            }
            await pub.send(json.dumps({"op": "publish", "topic": "/joint_states", "msg": msg}))
            await asyncio.sleep(max(0.0, t0 + (k + 1) / RATE_HZ - time.perf_counter()))
        got: list[int] = []
        latencies: list[float] = []
        for w in workers:
            line = await asyncio.wait_for(w.stdout.readline(), 60)  # type: ignore[union-attr]
            result = json.loads(line)
            got += result["received"]
            latencies += result["latencies"]
        await pub.close()
    finally:
        for w in workers:
            if w.returncode is None:
                with contextlib.suppress(ProcessLookupError):
                    w.kill()
            await w.wait()
    lat = np.array(latencies) if latencies else np.array([np.nan])
    return {
        "clients": n,
        "processes": len(workers),
        "sent": total,
        "received_min": min(got),
        "lost_total": int(sum(total - g for g in got)),
        "latency_median_ms": float(np.median(lat) * 1e3),
        "latency_p99_ms": float(np.percentile(lat, 99) * 1e3),
    }


def _stats(t: np.ndarray) -> dict[str, float]:
    return {
        "median_ms": float(np.median(t) * 1e3),
        "p99_ms": float(np.percentile(t, 99) * 1e3),
        "calls": len(t),
    }


def _cpu_seconds(pid: int) -> float | None:
    """User + system CPU time of a process so far (Linux /proc), or None elsewhere."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


async def _measure(
    url: str, args: argparse.Namespace, ours: bool, advance, pid: int
) -> dict[str, Any]:
    out: dict[str, Any] = {"round_trip": {}, "fan_out": []}
    if ours:
        out["round_trip"]["bus service, inline"] = _stats(
            await _round_trips(url, "/bench/echo", args.calls)
        )
        advance()
        out["round_trip"]["bus service, worker thread"] = _stats(
            await _round_trips(url, "/bench/echo_threaded", args.calls)
        )
        advance()
    out["round_trip"]["service offered by a client"] = _stats(
        await _client_service_round_trips(url, args.calls)
    )
    advance()
    for n in [int(c) for c in args.clients.split(",") if c.strip()]:
        cpu0 = _cpu_seconds(pid)
        result = await _fan_out(url, n, args.seconds, args.queue_length)
        cpu1 = _cpu_seconds(pid)
        if cpu0 is not None and cpu1 is not None:
            # the server's CPU per message delivered to one subscriber
            delivered = max(1, n * result["sent"] - result["lost_total"])
            result["server_cpu_us_per_delivery"] = (cpu1 - cpu0) / delivered * 1e6
        out["fan_out"].append(result)
        advance()
    return out


# ---------------------------------------------------------------- the baseline


def rosbridge_rs_status(binary: str | None = None) -> tuple[str | None, str]:
    """(command to run rosbridge-server-rs, "") when it can run here, else (None, why)."""
    exe = binary or shutil.which("rosbridge-server-rs")
    if exe is None:
        return None, (
            "rosbridge-server-rs is not installed here (`pip install rosbridge-server-rs` in a "
            "scratch venv, then pass --rs-binary)"
        )
    if not os.environ.get("ROS_DISTRO"):
        probe = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=20)
        text = (probe.stdout + probe.stderr).strip().splitlines()
        why = text[-1] if text else f"exit code {probe.returncode}"
        return None, (
            f"rosbridge-server-rs (PyPI) is a ROS 2 node: its binary links librcl, librmw and "
            f"librosidl_runtime_c of a ROS 2 Humble or Jazzy install, which this machine does "
            f"not have; it says: {why!r}"
        )
    return exe, ""


# ---------------------------------------------------------------- entry


def run(args: argparse.Namespace) -> int:
    steps = 3 + len([c for c in args.clients.split(",") if c.strip()])
    port = free_port()
    cmd = [
        sys.executable,
        "-c",
        f"from robotrial.benchmarks.rosbridge import serve_for_bench; serve_for_bench({port})",
    ]
    results: dict[str, Any] = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": f"{os.cpu_count()} cores, no GPU",
        "rate_hz": RATE_HZ,
        "queue_length": args.queue_length,
    }
    with progress("rosbridge bench", steps, enabled=not args.json) as advance:
        with server_process(cmd, port) as proc:
            results["robotrial"] = asyncio.run(
                _measure(f"ws://127.0.0.1:{port}/", args, True, advance, proc.pid)
            )
    rs_cmd, why = rosbridge_rs_status(args.rs_binary)
    if rs_cmd is None:
        results["rosbridge_server_rs"] = {"skipped": why}
    else:
        rs_port = free_port()
        try:
            with server_process([rs_cmd, "--port", str(rs_port)], rs_port) as proc:
                results["rosbridge_server_rs"] = asyncio.run(
                    _measure(f"ws://127.0.0.1:{rs_port}/", args, False, lambda: None, proc.pid)
                )
        except RuntimeError as exc:
            results["rosbridge_server_rs"] = {"skipped": f"rosbridge-server-rs did not run: {exc}"}
    write_result(results, args.output)
    if args.json:
        print_json(results)
        return 0
    rows = []
    for server in ("robotrial", "rosbridge_server_rs"):
        r = results[server]
        if "skipped" in r:
            continue
        for name, s in r["round_trip"].items():
            rows.append([server, name, s["median_ms"], s["p99_ms"], s["calls"]])
    print_table("service round trip (ms)", ["server", "service", "median", "p99", "calls"], rows)
    rows = []
    for server in ("robotrial", "rosbridge_server_rs"):
        r = results[server]
        if "skipped" in r:
            continue
        for f in r["fan_out"]:
            rows.append(
                [
                    server,
                    f["clients"],
                    f["sent"],
                    f["received_min"],
                    f["lost_total"],
                    f["latency_median_ms"],
                    f["latency_p99_ms"],
                    f.get("server_cpu_us_per_delivery", float("nan")),
                ]
            )
    print_table(
        f"/joint_states at {RATE_HZ:g} Hz, queue_length {args.queue_length}",
        [
            "server",
            "clients",
            "sent",
            "min received",
            "lost",
            "latency median ms",
            "p99 ms",
            "server CPU us/delivery",
        ],
        rows,
    )
    if "skipped" in results["rosbridge_server_rs"]:
        print(f"baseline not measured: {results['rosbridge_server_rs']['skipped']}")
    print(f"results: {args.output}")
    return 0
