"""The server goes away and comes back: the page (roslibjs) and a roslibpy client both
reconnect by themselves and carry on, and the page keeps what the user set."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
import roslibpy
from playwright.sync_api import sync_playwright

from ..conftest import free_port

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.timeout(180)]
STATUS = "window.robotrial.state().connection.status"


def _start(port: int, log: Path) -> subprocess.Popen:
    command = [Path(sys.executable).with_name("robotrial"), "serve", "--port", str(port)]
    with log.open("a") as errors:
        proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=errors)
    deadline = time.monotonic() + 30
    while True:
        try:
            httpx.get(f"http://127.0.0.1:{port}/api/config", timeout=1).raise_for_status()
            return proc
        except httpx.HTTPError:
            assert proc.poll() is None, log.read_text()
            assert time.monotonic() < deadline, "serve did not answer in 30 s"
            time.sleep(0.1)


def _until(cond, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, what
        time.sleep(0.1)


def test_page_and_roslibpy_reconnect_after_a_restart(chromium, chromium_args, tmp_path):
    port = free_port()
    log = tmp_path / "serve.log"
    server = _start(port, log)
    ros = roslibpy.Ros(f"ws://127.0.0.1:{port}/rosbridge")
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium, args=chromium_args)
            page = browser.new_page()
            page.goto(f"http://127.0.0.1:{port}/")
            page.wait_for_function(f"window.robotrial && {STATUS} === 'connected'", timeout=30_000)
            page.locator("input[data-joint]").first.fill("0.7")
            page.wait_for_function("window.robotrial.state().joints.values[0] === 0.7")
            ros.run(timeout=10)

            server.send_signal(signal.SIGKILL)
            server.wait()
            page.wait_for_function(f"{STATUS} !== 'connected'", timeout=15_000)
            _until(lambda: not ros.is_connected, 15, "roslibpy did not notice the drop")

            server = _start(port, log)
            page.wait_for_function(f"{STATUS} === 'connected'", timeout=30_000)
            assert page.evaluate("window.robotrial.state().joints.values[0]") == 0.7
            _until(lambda: ros.is_connected, 30, "roslibpy did not reconnect")
            answer = roslibpy.Service(ros, "/rosapi/get_time", "rosapi/GetTime").call(
                roslibpy.ServiceRequest(), timeout=10
            )
            assert answer["time"]["sec"] > 0
            browser.close()
    finally:
        ros.close()
        server.terminate()
        server.wait(10)
