# SPDX-License-Identifier: Apache-2.0
"""The console's HTTP + WebSocket server (aiohttp).

The page uses only this API (docs/reference/console-api.md, schema in
``openapi.json`` beside this file, served at ``/api/openapi.json``).

Protection: bound to loopback by default. With a token every request must
carry it (``Authorization: Bearer TOKEN``, the cookie the page gets, or
``?token=``); a bind to another address needs a token and TLS (checked by
the command before the server starts). Every POST must be JSON
(``Content-Type: application/json``) and every request that carries an
``Origin`` must come from this server's own origin: a web page of another
site in the operator's browser can neither command the platform nor open
the WebSocket.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from ..operator.node import NoAnswer, OpError, Refused
from . import validate
from .hub import BusDown, Conflict, Forbidden, Hub

STATIC = Path(__file__).parent / "static"
SCHEMA = Path(__file__).parent / "openapi.json"
COOKIE = "stewart_console_token"
HUB = web.AppKey("hub", Hub)
CFG = web.AppKey("cfg", dict)


def _error(status: int, message: str, **extra) -> web.Response:
    return web.json_response({"ok": False, "error": message, **extra}, status=status)


def _token_of(request: web.Request) -> str | None:
    auth = request.headers.get("Authorization", "")
    if auth.startswith("Bearer "):
        return auth[7:].strip()
    return request.cookies.get(COOKIE) or request.query.get("token")


@web.middleware
async def guard(request: web.Request, handler):
    cfg = request.app[CFG]
    token = cfg.get("token")
    if token:
        given = _token_of(request)
        if given is None or not hmac.compare_digest(given.encode(), token.encode()):
            return _error(401, "missing or wrong token (Authorization: Bearer TOKEN, or ?token= on the page's URL)")
    origin = request.headers.get("Origin")
    if origin is not None and origin != "null":
        if urlsplit(origin).netloc != request.host:
            return _error(403, f"cross-origin request from {origin} refused")
    if request.method == "POST" and request.content_type != "application/json":
        return _error(415, "POST bodies are JSON (Content-Type: application/json)")
    try:
        resp = await handler(request)
    except MAPPED as e:  # the API's errors (_mapped): one place for every handler
        return _mapped(e)
    if token and request.query.get("token") and isinstance(resp, web.StreamResponse):
        resp.set_cookie(COOKIE, token, httponly=True, samesite="Strict", secure=bool(cfg.get("tls")))
    return resp


async def _json(request: web.Request):
    try:
        return await request.json()
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise web.HTTPBadRequest(text=json.dumps({"ok": False, "error": "the body is not valid JSON"}),
                                 content_type="application/json") from None


def _client(request: web.Request) -> str | None:
    cid = request.headers.get("X-Console-Client")
    request.app[HUB].touch(cid)
    return cid


async def _blocking(request: web.Request, fn, *args):
    loop = asyncio.get_running_loop()
    return await loop.run_in_executor(request.app[CFG]["pool"], fn, *args)


MAPPED = (validate.BadRequest, validate.OutOfRange, Forbidden, Conflict, BusDown, OpError)


def _mapped(e: Exception) -> web.Response:
    if isinstance(e, (validate.BadRequest, validate.OutOfRange)):
        return _error(e.status, str(e), kind="bad_request" if e.status == 400 else "out_of_range")
    if isinstance(e, Forbidden):
        return _error(403, str(e), kind="observer")
    if isinstance(e, Conflict):
        return _error(409, str(e), kind="conflict")
    if isinstance(e, Refused):
        return _error(409, str(e), kind="refused")
    if isinstance(e, BusDown):
        return _error(503, str(e), kind="bus")
    if isinstance(e, NoAnswer):
        return _error(504, str(e), kind="no_answer")
    if isinstance(e, OpError):
        return _error(503, str(e), kind="bus")
    raise e


# -- handlers -----------------------------------------------------------------------

async def index(request: web.Request) -> web.StreamResponse:
    return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})


async def get_config(request: web.Request) -> web.Response:
    p = request.app[HUB].platform
    return web.json_response({
        "name": p.name, "base_joints": p.base_joints, "platform_joints": p.platform_joints, "home": p.home,
        "park": p.park, "leg_length_min": p.leg_length_min, "leg_length_max": p.leg_length_max,
        "workspace_min": p.workspace_min, "workspace_max": p.workspace_max,
        "force_limit": validate.FORCE_LIMIT_N, "moment_limit": validate.MOMENT_LIMIT_NM,
        "force_max": p.force_max, "sensor_mount": p.force_sensor.get("mount_pos", [0, 0, 0]),
        "udp": request.app[CFG].get("udp"), "commands": list(validate.COMMANDS)})


async def get_state(request: web.Request) -> web.Response:
    return web.json_response(request.app[HUB].snapshot())


async def get_events(request: web.Request) -> web.Response:
    return web.json_response(list(request.app[HUB].events))


async def schema(request: web.Request) -> web.StreamResponse:
    return web.FileResponse(SCHEMA)


async def post_session(request: web.Request) -> web.Response:
    body = await _json(request)
    name = body.get("name", "") if isinstance(body, dict) else ""
    c = request.app[HUB].new_client(name if isinstance(name, str) else "")
    return web.json_response({"ok": True, "client": c.id, "lease_s": request.app[HUB].lease_s})


async def post_control(request: web.Request) -> web.Response:
    hub = request.app[HUB]
    cid = _client(request)
    body = await _json(request)
    if not isinstance(body, dict) or body.get("action") not in ("claim", "release", "keepalive"):
        return _error(400, "action: one of claim, release, keepalive", kind="bad_request")
    takeover = body.get("takeover", False)
    if not isinstance(takeover, bool):
        return _error(400, "takeover: expected true or false", kind="bad_request")
    if body["action"] == "claim":
        return web.json_response({"ok": True, **hub.claim(cid, takeover)})
    if hub.touch(cid) is None:
        raise Forbidden("unknown client: open a session first")
    if body["action"] == "release":
        return web.json_response({"ok": True, **hub.release(cid)})
    return web.json_response({"ok": True, **hub.control()})


async def post_command(request: web.Request) -> web.Response:
    hub = request.app[HUB]
    cid = _client(request)
    body = await _json(request)
    if isinstance(body, dict) and body.get("command") == "estop":  # from anyone, never held back
        return web.json_response(await _blocking(request, hub.estop, cid))
    hub.require_commander(cid)
    st = hub.node.status
    try:
        req = validate.parse_command(body, hub.platform, st.pose if st and st.estimate_valid else None)
    except (validate.BadRequest, validate.OutOfRange) as e:
        hub.event("command", f"refused: {e}", ok=False)
        raise
    return web.json_response(await _blocking(request, hub.execute, cid, req))


async def post_estop(request: web.Request) -> web.Response:
    return web.json_response(await _blocking(request, request.app[HUB].estop, _client(request)))


async def post_recording(request: web.Request) -> web.Response:
    hub = request.app[HUB]
    cid = _client(request)
    body = await _json(request)
    action = body.get("action") if isinstance(body, dict) else None
    if action not in ("start", "stop"):
        return _error(400, "action: start or stop", kind="bad_request")
    hub.require_commander(cid)
    if action == "start":
        try:
            info = hub.recorder.start()
        except ValueError as e:
            return _error(409, str(e), kind="conflict")
        hub.event("recording", f"recording {info['name']} started")
        return web.json_response({"ok": True, **info})
    done = hub.recorder.stop()
    if done is None:
        return _error(409, "no recording is running", kind="conflict")
    hub.event("recording", f"recording {done['name']} stopped: {done['frames']} frames, {done['seconds']:.1f} s")
    return web.json_response({"ok": True, **done})


async def get_recordings(request: web.Request) -> web.Response:
    return web.json_response(request.app[HUB].recorder.list())


async def get_recording_file(request: web.Request) -> web.StreamResponse:
    p = request.app[HUB].recorder.path(request.match_info["name"], request.match_info["file"])
    if p is None:
        return _error(404, "no such recording or file (finished recordings: GET /api/recordings)")
    name = request.match_info["name"] + "-" + p.name
    disp = "inline" if p.suffix == ".png" else f'attachment; filename="{name}"'
    return web.FileResponse(p, headers={"Content-Disposition": disp})


async def websocket(request: web.Request) -> web.StreamResponse:
    hub = request.app[HUB]
    ws = web.WebSocketResponse(heartbeat=5.0, max_msg_size=1 << 14)
    await ws.prepare(request)
    cid = request.query.get("client")
    c = hub.touch(cid) or hub.new_client(request.query.get("name", ""))
    hub.socket_opened(c.id)
    request.app[CFG]["sockets"].add(ws)
    try:
        await ws.send_json({"type": "hello", "client": c.id, "lease_s": hub.lease_s})
        await ws.send_str(json.dumps(hub.snapshot(), separators=(",", ":")))  # the page shows it at once
        async for msg in ws:
            if msg.type != WSMsgType.TEXT:
                continue
            await _ws_message(request, ws, c.id, msg.data)
    finally:
        request.app[CFG]["sockets"].discard(ws)
        hub.socket_closed(c.id)
    return ws


async def _ws_message(request, ws, cid: str, text: str) -> None:
    """WebSocket messages from the page: ESTOP (the fastest way) and pings."""
    try:
        m = json.loads(text)
    except json.JSONDecodeError:
        await ws.send_json({"type": "error", "error": "not JSON"})
        return
    if not isinstance(m, dict):
        return
    if m.get("type") == "estop":
        try:
            res = await _blocking(request, request.app[HUB].estop, cid)
            await ws.send_json({"type": "estop", **res, "id": m.get("id")})
        except (BusDown, NoAnswer) as e:
            await ws.send_json({"type": "estop", "ok": False, "error": str(e), "id": m.get("id")})
    elif m.get("type") == "ping":
        await ws.send_json({"type": "pong", "id": m.get("id"), "t": time.time()})


async def _broadcast(app: web.Application) -> None:
    hub, cfg = app[HUB], app[CFG]
    period = 1.0 / cfg.get("rate", 30.0)
    last_event = 0
    while True:
        t0 = time.monotonic()
        socks = list(cfg["sockets"])
        if socks:
            snap = hub.snapshot()
            if snap["events_seq"] != last_event:
                snap["events"] = [e for e in hub.events if e["seq"] > last_event]
                last_event = snap["events_seq"]
            text = json.dumps(snap, separators=(",", ":"))
            for ws in socks:
                if not ws.closed:
                    try:
                        await ws.send_str(text)
                    except (ConnectionError, RuntimeError):
                        pass
        await asyncio.sleep(max(0.0, period - (time.monotonic() - t0)))


async def _on_startup(app: web.Application) -> None:
    app[CFG]["task"] = asyncio.create_task(_broadcast(app))


async def _on_cleanup(app: web.Application) -> None:
    app[CFG]["task"].cancel()
    for ws in list(app[CFG]["sockets"]):
        await ws.close()
    app[CFG]["pool"].shutdown(wait=False, cancel_futures=True)


def make_app(hub: Hub, token: str | None = None, tls: bool = False, rate: float = 30.0,
             udp: str | None = None) -> web.Application:
    app = web.Application(middlewares=[guard], client_max_size=1 << 16)
    app[HUB] = hub
    app[CFG] = {"token": token, "tls": tls, "rate": rate, "udp": udp, "sockets": set(),
                "pool": ThreadPoolExecutor(max_workers=4, thread_name_prefix="console-cmd")}
    r = app.router
    r.add_get("/", index)
    r.add_get("/api/config", get_config)
    r.add_get("/api/state", get_state)
    r.add_get("/api/events", get_events)
    r.add_get("/api/openapi.json", schema)
    r.add_post("/api/session", post_session)
    r.add_post("/api/control", post_control)
    r.add_post("/api/command", post_command)
    r.add_post("/api/estop", post_estop)
    r.add_post("/api/recording", post_recording)
    r.add_get("/api/recordings", get_recordings)
    r.add_get("/api/recordings/{name}/{file}", get_recording_file)
    r.add_get("/api/ws", websocket)
    r.add_static("/static", STATIC, show_index=False)
    app.on_startup.append(_on_startup)
    app.on_cleanup.append(_on_cleanup)
    return app
