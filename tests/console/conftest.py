# SPDX-License-Identifier: Apache-2.0
"""The console's tests: the suite's throw-away machine key (testkey's hooks),
a stand-in platform (fake_platform.py) and the console's server in this
process on python-can's ``virtual`` interface."""

from __future__ import annotations

import asyncio
import itertools
import json
import socket
import sys
import threading
import urllib.error
import urllib.request
from pathlib import Path

import can
import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tools" / "dev"))
sys.path.insert(0, str(HERE))
from testkey import pytest_configure, pytest_unconfigure  # noqa: E402, F401

_ids = itertools.count()


def free_port(kind=socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class FakeRun:
    """fake_platform.Fake on three virtual buses, in a thread."""

    def __init__(self):
        from stewart import auth
        from fake_platform import Fake

        n = next(_ids)
        self.channels = [f"console-{n}-{b}" for b in ("ops", "axis_a", "axis_b")]
        buses = {b: can.Bus(interface="virtual", channel=c, receive_own_messages=False)
                 for b, c in zip(("ops", "axis_a", "axis_b"), self.channels)}
        self.fake = Fake(buses, auth.read_key(auth.key_file()))
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.fake.run, args=(self.stop,), daemon=True)
        self.thread.start()

    def close(self):
        self.stop.set()
        self.thread.join(2)
        for b in self.fake.buses.values():
            b.shutdown()


class ConsoleRun:
    """The console's hub and server (on a free port) in a thread with its own loop."""

    def __init__(self, fake: FakeRun, tmp: Path, token: str | None = None, lease: float = 1.0):
        from aiohttp import web

        from stewart import auth, config, resources
        from stewart.console.hub import Hub
        from stewart.console.server import make_app

        self.fake = fake
        ops = can.Bus(interface="virtual", channel=fake.channels[0], receive_own_messages=False)
        axis = {b: can.Bus(interface="virtual", channel=c, receive_own_messages=False)
                for b, c in zip(("axis_a", "axis_b"), fake.channels[1:])}
        plat = config.load(resources.default_platform())
        self.hub = Hub(ops, plat, auth.read_key(auth.key_file()), axis, lease_s=lease, record_dir=tmp).start()
        self.udp_port = free_port(socket.SOCK_DGRAM)
        self.hub.start_udp("127.0.0.1", self.udp_port, 200.0)
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.token = token
        app = make_app(self.hub, token=token)
        self.loop = asyncio.new_event_loop()
        self.runner = web.AppRunner(app)
        ready = threading.Event()

        def serve():
            asyncio.set_event_loop(self.loop)
            self.loop.run_until_complete(self.runner.setup())
            self.loop.run_until_complete(web.TCPSite(self.runner, "127.0.0.1", self.port).start())
            ready.set()
            self.loop.run_forever()

        self.thread = threading.Thread(target=serve, daemon=True)
        self.thread.start()
        ready.wait(10)

    def http(self, method: str, path: str, body=None, client: str | None = None, headers=None,
             raw: bytes | None = None):
        """(status, JSON answer)."""
        h = {"Content-Type": "application/json"} if body is not None or raw is not None else {}
        if client:
            h["X-Console-Client"] = client
        if self.token:
            h["Authorization"] = f"Bearer {self.token}"
        h.update(headers or {})
        data = raw if raw is not None else (json.dumps(body).encode() if body is not None else None)
        req = urllib.request.Request(self.url + path, data=data, method=method, headers=h)
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                return r.status, json.loads(r.read() or b"null")
        except urllib.error.HTTPError as e:
            text = e.read()
            try:
                return e.code, json.loads(text)
            except json.JSONDecodeError:
                return e.code, {"error": text.decode(errors="replace")}

    def session(self, name: str = "test") -> str:
        status, j = self.http("POST", "/api/session", {"name": name})
        assert status == 200, j
        return j["client"]

    def close(self):
        fut = asyncio.run_coroutine_threadsafe(self.runner.cleanup(), self.loop)
        try:
            fut.result(5)
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(5)
            self.hub.close()


@pytest.fixture()
def fake():
    f = FakeRun()
    yield f
    f.close()


@pytest.fixture()
def console(fake, tmp_path):
    c = ConsoleRun(fake, tmp_path, lease=30.0)
    yield c
    c.close()
