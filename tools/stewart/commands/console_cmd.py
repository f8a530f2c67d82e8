# SPDX-License-Identifier: Apache-2.0
"""``stewart console``: the operator's console in the browser
(docs/guides/console.md; the API: docs/reference/console-api.md)."""

from __future__ import annotations

import ipaddress
import os
import sys

from .. import busopts

TOKEN_ENV = "STEWART_CONSOLE_TOKEN"


def register(sub) -> None:
    p = sub.add_parser("console", help="the operator's console: a local web application (3-D view, legs, "
                       "faults, commands, recordings) and its HTTP + WebSocket API")
    busopts.add_arguments(p, "ops")
    p.add_argument("--axis-channels", metavar="A,B", help="the drive buses' channels on the same interface "
                   "(legs' lengths and pressures, the force/torque sensor); default with socketcan: vcan1,vcan2; "
                   "'none': the ops bus only")
    p.add_argument("--axis-contexts", metavar="A,B", help="the drive buses from these sections of the "
                   "python-can configuration (--can-config) instead of --axis-channels")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default loopback; another needs "
                   "--token and --tls-cert/--tls-key)")
    p.add_argument("--port", type=int, default=8080)
    p.add_argument("--token", help=f"access token (default: ${TOKEN_ENV}); required off loopback")
    p.add_argument("--tls-cert", metavar="PEM")
    p.add_argument("--tls-key", metavar="PEM")
    p.add_argument("--key", metavar="FILE", help="the machine key that signs commands (default: $STEWART_KEY; "
                   "docs/explanation/security.md): it stays in this process")
    p.add_argument("--platform", metavar="JSON", help="platform configuration (default: the packaged one)")
    p.add_argument("--udp", default="127.0.0.1:47600", metavar="HOST:PORT",
                   help="send the measured pose here over UDP ('off': none; default %(default)s)")
    p.add_argument("--udp-rate", type=float, default=200.0, help="UDP pose datagrams per second (>= 100)")
    p.add_argument("--rate", type=float, default=30.0, help="state updates per second to each page (10..60)")
    p.add_argument("--lease", type=float, default=1.0, help="s an HTTP-only commander stays alive without "
                   "a request (a page's WebSocket keeps it alive)")
    p.add_argument("--silent-after", type=float, default=0.5, metavar="S",
                   help="no CTRL_STATUS for this long: the controller is taken for gone and commands but ESTOP "
                        "are refused (default %(default)s s; more for a simulation on a loaded machine)")
    p.add_argument("--record-dir", default="out/console", help="where recordings go")
    p.set_defaults(func=run)


def _err(text: str) -> int:
    print(f"stewart console: {text}", file=sys.stderr)
    return 2


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_exposure(host: str, token: str | None, cert: str | None, key: str | None) -> str | None:
    """Why the console must not start with these options, or None."""
    if bool(cert) != bool(key):
        return "--tls-cert and --tls-key go together"
    if _is_loopback(host):
        return None
    missing = [w for w, ok in (("a token (--token or $" + TOKEN_ENV + ")", bool(token)),
                               ("TLS (--tls-cert and --tls-key)", bool(cert))) if not ok]
    if missing:
        return (f"binding to {host} (not loopback) needs {' and '.join(missing)}: "
                "anyone who reaches the port could otherwise command the platform")
    if len(token) < 16:
        return "the token must have at least 16 characters"
    return None


def _open_buses(args):
    from ..busopts import BusError, open_bus, resolve

    opts = busopts.options(args)
    ops = open_bus(opts)
    if args.axis_contexts:  # two sections of python-can's configuration
        attr, option, names = "context", "--axis-contexts: two sections, A,B", args.axis_contexts.split(",")
    else:  # two channels of the ops bus's interface (SocketCAN: vcan1,vcan2 unless told)
        chans = args.axis_channels
        if chans is None and resolve(opts)["interface"] == "socketcan":
            chans = "vcan1,vcan2"
        attr, option = "channel", "--axis-channels: two channels, A,B"
        names = chans.split(",") if chans and chans != "none" else []
    if names and len(names) != 2:
        raise BusError(option)
    axis = {}
    for bus, name in zip(("axis_a", "axis_b"), names):
        o = busopts.options(args)
        setattr(o, attr, name)
        o.bus = bus
        axis[bus] = open_bus(o)
    return ops, axis


def _ssl(args):
    if not args.tls_cert:
        return None
    import ssl

    ctx = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    ctx.load_cert_chain(args.tls_cert, args.tls_key)
    return ctx


def run(args) -> int:
    from .. import auth as au
    from .. import config as cf
    from .. import resources
    from ..busopts import BusError

    token = args.token or os.environ.get(TOKEN_ENV) or None
    why = check_exposure(args.host, token, args.tls_cert, args.tls_key)
    if why:
        return _err(why)
    if not 100.0 <= args.udp_rate <= 2000.0 or not 10.0 <= args.rate <= 60.0:
        return _err("--udp-rate is 100..2000 and --rate 10..60 per second")
    if not 0.05 <= args.silent_after <= 60.0 or not 0.1 <= args.lease <= 60.0:
        return _err("--silent-after is 0.05..60 s and --lease 0.1..60 s")
    udp = None
    if args.udp != "off":
        from ..operator.sources import SourceError, parse_host_port

        try:
            udp = parse_host_port(args.udp)
        except SourceError as e:
            return _err(f"--udp: {e}")
    try:
        key = au.machine_key(args.key)
    except au.AuthError as e:
        return _err(str(e))
    try:
        ssl_ctx = _ssl(args)
    except (OSError, ValueError) as e:
        return _err(f"TLS: {e}")
    try:
        platform = cf.load(args.platform or resources.default_platform())
    except (cf.ConfigError, OSError) as e:
        return _err(f"--platform: {e}")
    try:
        ops, axis = _open_buses(args)
    except BusError as e:
        return _err(str(e))
    return _serve(args, ops, axis, platform, key, token, ssl_ctx, udp)


def _serve(args, ops, axis, platform, key, token, ssl_ctx, udp) -> int:
    from aiohttp import web

    from ..console.hub import Hub
    from ..console.server import make_app

    hub = Hub(ops, platform, key, axis, lease_s=args.lease, record_dir=args.record_dir,
              stale_s=args.silent_after).start()
    if udp is not None:
        hub.start_udp(udp[0], udp[1], args.udp_rate)
    if key is None:
        print("stewart console: no machine key ($STEWART_KEY or --key): commands that start or change "
              "motion will be refused; STOP, PARK and ESTOP work", file=sys.stderr)
    app = make_app(hub, token=token, tls=ssl_ctx is not None, rate=args.rate,
                   udp=f"{udp[0]}:{udp[1]}" if udp else None)
    scheme = "https" if ssl_ctx else "http"
    print(f"stewart console: {scheme}://{args.host}:{args.port}/"
          + ("?token=..." if token else "") + (f", pose over UDP to {udp[0]}:{udp[1]}" if udp else ""), flush=True)
    try:
        web.run_app(app, host=args.host, port=args.port, ssl_context=ssl_ctx, print=None,
                    handle_signals=True, shutdown_timeout=1.0)
    except OSError as e:
        return _err(f"cannot listen on {args.host}:{args.port}: {e}")
    finally:
        hub.close()
    return 0
