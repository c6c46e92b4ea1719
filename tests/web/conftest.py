"""Fixtures of the browser tests: the real `robotrial serve` in a subprocess."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx
import pytest


@pytest.fixture(scope="module")
def serve(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Callable[..., str]]:
    """Start `robotrial serve ARGS...` on a free loopback port and return the page's URL,
    once the server prints that URL and answers /api/config (401 with --token); stopped at
    the module's end."""
    procs: list[subprocess.Popen] = []

    def start(*args: str, timeout: float = 30.0) -> str:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        log = tmp_path_factory.mktemp("serve") / "serve.log"
        command = [Path(sys.executable).with_name("robotrial"), "serve", "--port", str(port)]
        if "--foxglove-port" not in args:  # one port for every server: off unless asked
            command += ["--foxglove-port", "0"]
        with log.open("w") as errors:
            proc = subprocess.Popen(
                [*command, *args], stdout=subprocess.PIPE, stderr=errors, text=True
            )
        procs.append(proc)
        url = f"http://127.0.0.1:{port}/"
        line = proc.stdout.readline() if proc.stdout else ""
        if "Foxglove is off" in line:  # a busy Foxglove port is said first
            line = proc.stdout.readline()
        assert url in line, f"serve printed {line!r}; stderr: {log.read_text()}"
        deadline = time.monotonic() + timeout
        while True:
            try:
                answer = httpx.get(url + "api/config", timeout=1)
                if answer.status_code != 401:
                    answer.raise_for_status()
                return url
            except httpx.HTTPError:
                assert proc.poll() is None, f"serve exited: {log.read_text()}"
                assert time.monotonic() < deadline, f"serve did not answer within {timeout} s"
                time.sleep(0.1)

    yield start
    for proc in procs:
        proc.terminate()
    for proc in procs:
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:  # a stop that hangs is not what these tests check
            proc.kill()
            proc.wait(10)


@pytest.fixture(scope="module")
def browser(chromium: str, chromium_args: list[str]) -> Iterator:
    """Headless Chromium for a module's tests (new pages or contexts per test)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=chromium, args=chromium_args)
        yield b
        b.close()
