# SPDX-License-Identifier: Apache-2.0
"""The console's API without a browser: who commands, bad input, the bus
going away, the UDP pose output; against the stand-in platform on python-can's
``virtual`` interface (fake_platform.py). Each bad request must get a clear
refusal and leave the platform where it was."""

from __future__ import annotations

import socket
import struct
import time

import pytest

from stewart.commands import console_cmd
from stewart.console import hub as hubmod


def wait_state(console, want, timeout=5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        st = console.hub.node.status
        if st is not None and st.state == want:
            return st
        time.sleep(0.01)
    raise AssertionError(f"state {console.hub.node.status.state if console.hub.node.status else None}, "
                         f"wanted {want}")


def commander(console, name="op"):
    cid = console.session(name)
    status, j = console.http("POST", "/api/control", {"action": "claim"}, client=cid)
    assert status == 200 and j["commander"] == cid, j
    return cid


def test_engage_run_stop_estop_reset(console):
    cid = commander(console)
    wait_state(console, "IDLE")
    status, j = console.http("POST", "/api/command", {"command": "engage"}, client=cid)
    assert status == 200, j
    wait_state(console, "READY")
    status, j = console.http("POST", "/api/command", {"command": "run", "axis": "x", "amplitude": 0.05,
                                                      "frequency": 1.0}, client=cid)
    assert status == 200 and j["state"] == "RUNNING", j
    time.sleep(0.3)
    assert abs(console.hub.node.status.pose[0]) > 0.005  # the platform moves
    status, j = console.http("POST", "/api/command", {"command": "stop"}, client=cid)
    assert status == 200 and j["state"] == "READY", j
    observer = console.session("watcher")
    status, j = console.http("POST", "/api/estop", {}, client=observer)  # ESTOP from anyone
    assert status == 200 and j["state"] == "ESTOP", j
    status, j = console.http("POST", "/api/command", {"command": "reset"}, client=cid)
    assert status == 200 and j["state"] == "READY", j  # RESET re-engages, as the controller does


def test_observer_and_second_commander_are_refused(console):
    first = commander(console, "first")
    second = console.session("second")
    before = list(console.fake.fake.pose)
    status, j = console.http("POST", "/api/command", {"command": "engage"}, client=second)
    assert status == 403 and "observes" in j["error"], j
    status, j = console.http("POST", "/api/control", {"action": "claim"}, client=second)
    assert status == 409 and "take over" in j["error"], j
    status, j = console.http("POST", "/api/command", {"command": "engage"})  # no client at all
    assert status == 403
    time.sleep(0.1)
    assert console.fake.fake.state == "IDLE" and list(console.fake.fake.pose) == before  # nothing moved
    status, j = console.http("POST", "/api/control", {"action": "claim", "takeover": True}, client=second)
    assert status == 200 and j["commander"] == second
    status, j = console.http("POST", "/api/command", {"command": "engage"}, client=first)
    assert status == 403, j
    assert console.fake.fake.state == "IDLE"


@pytest.mark.parametrize("body, code, words", [
    ({"command": "fly"}, 400, "command: one of"),
    ([1, 2], 400, "JSON object"),
    ({"command": "move", "pose": [0, 0, 0]}, 400, "list of 6"),
    ({"command": "move", "pose": [0, 0, "a", 0, 0, 0]}, 400, "expected a number"),
    ({"command": "move", "pose": [0, 0, 0, 0, 0, 0], "relative": True, "x": 1}, None, None),
    ({"command": "move", "pose": [0.6, 0, 0, 0, 0, 0], "relative": True}, 422, "outside the workspace"),
    ({"command": "move", "pose": [0, 0, 0, 0, 0, 0]}, 422, "outside the workspace"),  # absolute: z 0 m
    ({"command": "run", "axis": "x", "amplitude": 0.05, "frequency": 50}, 422, "frequency"),
    ({"command": "run", "axis": "w", "amplitude": 0.05, "frequency": 1}, 400, "axis"),
    ({"command": "force", "axes": "z", "target": [0, 0, -9000, 0, 0, 0]}, 422, "limit 8000"),
    ({"command": "force", "axes": "q", "target": [0] * 6}, 400, "unknown axis"),
    ({"command": "force", "axes": "z", "target": [0] * 6, "params": {"mass": -1, "damping": 1e4,
                                                                     "stiffness": 0}}, 422, "mass"),
    ({"command": "feedforward", "on": "yes"}, 400, "true or false"),
    ({"command": "jog", "axis": "x", "step": 1.0}, 422, "step"),
])
def test_bad_payloads_are_refused_and_nothing_moves(console, body, code, words):
    cid = commander(console)
    wait_state(console, "IDLE")
    sent = console.hub.node.counters.sent - console.hub.node.counters.heartbeats
    status, j = console.http("POST", "/api/command", body, client=cid)
    if code is None:  # a valid move in IDLE: the controller's refusal, with its reason
        assert status == 409 and "MOVE_TO" in j["error"] and "READY" in j["error"], j
        return
    assert status == code and words in j["error"], j
    assert console.hub.node.counters.sent - console.hub.node.counters.heartbeats == sent  # nothing sent
    assert console.fake.fake.state == "IDLE"


def test_malformed_requests(console):
    cid = commander(console)
    status, j = console.http("POST", "/api/command", raw=b"{not json", client=cid)
    assert status == 400 and "not valid JSON" in j["error"]
    status, j = console.http("POST", "/api/command", raw=b"command=engage", client=cid,
                             headers={"Content-Type": "application/x-www-form-urlencoded"})
    assert status == 415
    status, j = console.http("POST", "/api/command", {"command": "engage"}, client=cid,
                             headers={"Origin": "http://evil.example"})
    assert status == 403 and "cross-origin" in j["error"]
    status, j = console.http("POST", "/api/control", {"action": "grab"}, client=cid)
    assert status == 400
    assert console.fake.fake.state == "IDLE"


def test_controller_refusal_has_its_reason(console):
    cid = commander(console)
    wait_state(console, "IDLE")
    status, j = console.http("POST", "/api/command", {"command": "run", "axis": "x", "amplitude": 0.05,
                                                      "frequency": 1}, client=cid)
    assert status == 409 and j["kind"] == "refused" and "READY only" in j["error"], j
    status, j = console.http("GET", "/api/events")
    assert any(not e["ok"] and "RUN_TRIG" in e["text"] for e in j)


def test_the_bus_going_away(console):
    cid = commander(console)
    wait_state(console, "IDLE")
    console.fake.stop.set()  # the controller (or the bus) is gone
    time.sleep(hubmod.STALE_S + 0.2)
    status, j = console.http("GET", "/api/state")
    assert "silent" in j["bus_problem"]
    status, j = console.http("POST", "/api/command", {"command": "engage"}, client=cid)
    assert status == 503 and "silent" in j["error"], j


def test_token(fake, tmp_path):
    from conftest import ConsoleRun

    c = ConsoleRun(fake, tmp_path, token="a-long-enough-token-123")
    try:
        c.token = None
        status, j = c.http("GET", "/api/state")
        assert status == 401 and "token" in j["error"]
        c.token = "wrong-token-wrong-token"
        status, _ = c.http("GET", "/api/state")
        assert status == 401
        c.token = "a-long-enough-token-123"
        status, _ = c.http("GET", "/api/state")
        assert status == 200
    finally:
        c.close()


@pytest.mark.parametrize("host, token, cert, words", [
    ("0.0.0.0", None, None, "needs a token"),
    ("192.168.1.5", "a-long-enough-token-123", None, "TLS"),
    ("192.168.1.5", "short", "c.pem", "16 characters"),
    ("127.0.0.1", None, "c.pem", "go together"),
])
def test_exposure_without_token_or_tls_refused(host, token, cert, words):
    why = console_cmd.check_exposure(host, token, cert, None if words == "go together" else cert)
    assert why is not None and words in why
    assert console_cmd.check_exposure("127.0.0.1", None, None, None) is None
    assert console_cmd.check_exposure("::1", None, None, None) is None


def test_cli_refuses_a_public_bind_without_token(capsys, monkeypatch):
    from stewart import cli

    monkeypatch.delenv(console_cmd.TOKEN_ENV, raising=False)
    rc = cli.main(["console", "--host", "0.0.0.0", "-i", "virtual", "-c", "x"])
    assert rc == 2 and "needs a token" in capsys.readouterr().err


def test_udp_pose(console):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", console.udp_port))
    s.settimeout(1.0)
    try:
        t0, n, last = time.monotonic(), 0, None
        while time.monotonic() - t0 < 1.0:
            last = s.recv(256)
            n += 1
        rate = n / (time.monotonic() - t0)
    finally:
        s.close()
    magic, seq, tick, stamp, *rest = struct.unpack(hubmod.UDP_FORMAT, last)
    pose, state, valid = rest[:6], rest[6], rest[7]
    assert magic == b"SPP1" and valid == 1 and abs(pose[2] - 2.0) < 1e-3  # parked
    assert abs(stamp - time.time()) < 0.5
    assert rate >= 100.0, f"{rate:.0f} datagrams/s"


def test_schema_covers_the_routes_and_commands(console):
    import json as _json
    from pathlib import Path

    from stewart.console import server, validate

    schema = _json.loads(Path(server.SCHEMA).read_text())
    app = server.make_app(console.hub)
    routes = {r.resource.canonical for r in app.router.routes() if r.resource.canonical.startswith("/api/")}
    assert routes == set(schema["paths"])
    enum = schema["components"]["schemas"]["Command"]["properties"]["command"]["enum"]
    assert set(enum) == set(validate.COMMANDS)
    status, j = console.http("GET", "/api/openapi.json")
    assert status == 200 and j["openapi"].startswith("3.")


def test_commander_page_closed_stops_the_platform(console):
    """The commander's WebSocket closes while RUNNING: the heartbeat stops and
    the controller's operator supervision (200 ms) ends the motion."""
    import asyncio

    import aiohttp

    from fake_platform import BIT

    async def run():
        async with aiohttp.ClientSession() as s:
            ws = await s.ws_connect(console.url.replace("http", "ws") + "/api/ws?name=page")
            cid = (await ws.receive_json())["client"]
            loop = asyncio.get_running_loop()
            call = lambda *a, **k: loop.run_in_executor(None, lambda: console.http(*a, **k))  # noqa: E731
            assert (await call("POST", "/api/control", {"action": "claim"}, client=cid))[0] == 200
            assert (await call("POST", "/api/command", {"command": "engage"}, client=cid))[0] == 200
            await loop.run_in_executor(None, wait_state, console, "READY")
            st, j = await call("POST", "/api/command", {"command": "run", "axis": "z", "amplitude": 0.02,
                                                       "frequency": 1}, client=cid)
            assert st == 200, j
            await asyncio.sleep(0.3)
            assert not console.fake.fake.faults & BIT["operator_silent"]  # the heartbeat kept it going
            t0 = time.monotonic()
            await ws.close()
            return t0

    t0 = asyncio.run(run())
    while not console.fake.fake.faults & BIT["operator_silent"] and time.monotonic() - t0 < 3:
        time.sleep(0.005)
    dt = time.monotonic() - t0
    assert console.fake.fake.faults & BIT["operator_silent"], "the platform kept running"
    import os

    margin = 0.15 if os.getloadavg()[0] <= (os.cpu_count() or 1) else 1.0  # a loaded machine: scheduling
    assert dt <= 0.2 + margin, f"{dt * 1000:.0f} ms from the page's close to the stop"
    assert console.http("GET", "/api/state")[1]["control"]["commander"] is None
