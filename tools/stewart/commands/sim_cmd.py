# SPDX-License-Identifier: Apache-2.0
"""``stewart sim``: the simulated platform, in real time, until stopped.

    stewart sim [start] [--port N] [--run-dir DIR] [--backend auto|host|uml]
                [--relax TICKS] [--mem SIZE] [--key FILE] [--build DIR]
                [--operator-timeout TICKS] [--no-bridge]
    stewart sim status [--json]          the running simulation's figures
    stewart sim inject 'LINE' ...        scenario lines, played at once
    stewart sim stop                     stops it (as Ctrl-C does)

The controller (host build) and the simulated hexapod on vcan (the host's,
else inside a user-mode Linux); the buses for python-can programs on the
host: SocketCAN where the host has vcan, and python-can's ``socketcand``
interface on 127.0.0.1 (port 29536 by default): ``-i socketcand -c vcan0``.
Guide: docs/guides/simulator.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path



def _err(text: str) -> None:
    print(f"stewart sim: {text}", file=sys.stderr)


def _start(args) -> int:
    from .. import vcan
    from ..sim import control
    from ..sim.host import Host, Options

    opts = Options(run_dir=Path(args.run_dir), port=args.port, backend=args.backend, relax=args.relax,
                   mem=args.mem, key=Path(args.key) if args.key else None, build=args.build,
                   operator_timeout=args.operator_timeout, bridge=not args.no_bridge)
    host = Host(opts)
    try:
        host.start()
    except (vcan.VcanError, control.ControlError, OSError) as e:
        _err(str(e))
        host.abort()
        return 1
    _print_ready(host)
    host.wait()
    print("stewart sim: stopping", file=sys.stderr)
    bye = host.stop()
    _print_final(bye)
    return 0 if bye.get("ok") else 1


def _print_ready(host) -> None:
    a = host.attach()
    rt = "SCHED_FIFO" if (host.ready or {}).get("realtime") else "normal priority"
    where = "the host's vcan" if host.backend == "host" else "vcan inside a user-mode Linux"
    print(f"stewart sim: running in real time on {where} (controller and plant at {rt})")
    if "socketcan" in a:
        print("  SocketCAN: -i socketcan -c vcan0 (ops), vcan1 (axis_a), vcan2 (axis_b)")
    if "socketcand" in a:
        s = a["socketcand"]
        print(f"  python-can: -i socketcand -c vcan0 (ops) | vcan1 (axis_a) | vcan2 (axis_b), "
              f"host 127.0.0.1 port {s['port']}")
        print(f"     or --can-config {s['config']} (sections default, ops, axis_a, axis_b)")
        print(f"     e.g. STEWART_KEY={host.key} stewart op -i socketcand status")
        print(f"          python -m can.viewer -i socketcand -c vcan0 --host=127.0.0.1 --port={s['port']}")
    print(f"  machine key: {host.key} (export STEWART_KEY={host.key})")
    print("  stewart sim status | stewart sim inject 'LINE' | stewart sim stop; Ctrl-C stops it too")
    sys.stdout.flush()


def _print_final(bye: dict) -> None:
    import os

    ctl, plant = bye.get("controller", {}), bye.get("plant", {})
    print(f"stewart sim: host load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    if ctl:
        print(f"stewart sim: controller: {ctl.get('ticks', 0)} ticks, {ctl.get('deadline_misses', 0)} deadline "
              f"misses ({ctl.get('miss_percent', 0):.3f} %), worst {ctl.get('worst_late_ms', 0):.1f} ms late")
    if plant:
        print(f"stewart sim: plant: {plant.get('cycles', 0)} cycles, {plant.get('deadline_misses', 0)} deadline "
              f"misses ({plant.get('miss_percent', 0):.3f} %), worst {plant.get('worst_late_ms', 0):.1f} ms late")
    if not bye.get("ok"):
        _err(bye.get("error", "ended abnormally"))
        for name, lines in bye.get("tails", {}).items():
            for line in lines[-6:]:
                print(f"  {name}: {line}", file=sys.stderr)


def _client(args) -> int:
    from ..sim import control
    from ..sim.host import run_files

    path = run_files(Path(args.run_dir))["control"]
    try:
        if args.action == "stop":
            reply = control.call(path, {"op": "stop"})
            print(reply.get("answer", "stopping"))
            return 0 if reply.get("ok") else 1
        if args.action == "status":
            return _status(control.call(path, {"op": "status"}), args.json)
        rc = 0
        for line in args.lines:
            reply = control.call(path, {"op": "inject", "line": line})
            word = "accepted" if reply.get("ok") else "refused"
            print(f"{word}: {reply.get('answer', '')}")
            rc = rc or (0 if reply.get("ok") else 1)
        return rc
    except control.ControlError as e:
        _err(str(e))
        return 3


def _status(st: dict, as_json: bool) -> int:
    if as_json:
        print(json.dumps(st, indent=1))
        return 0 if st.get("ok") else 1
    if not st.get("ok"):
        _err(st.get("answer", "no status"))
        return 1
    prog = st.get("progress", {})
    load = st.get("host_load") or [0.0]
    print(f"running: {st.get('running')} ({st.get('backend')}), up {st.get('uptime_s', 0):.0f} s; controller "
          f"state {prog.get('state', '?')}; host load average {load[0]:.1f} on {st.get('host_cores')} cores")
    for name, unit in (("controller", "ticks"), ("plant", "cycles")):
        s = st.get(name, {})
        print(f"{name}: {s.get(unit, 0)} {unit}, deadline misses {s.get('deadline_misses', 0)} "
              f"({s.get('miss_percent', 0):.3f} %), worst {s.get('worst_late_ms', 0):.1f} ms late")
    if prog.get("pose"):
        x, y, z, yaw = prog["pose"]
        print(f"pose: x {x:+.4f} y {y:+.4f} z {z:.4f} m, yaw {yaw:+.4f} rad")
    for e in st.get("events", [])[-5:]:
        print(f"event: {e}")
    r = st.get("relay", {})
    print(f"relay: {r.get('to_host', 0)} frames to the host ({r.get('dropped', 0)} dropped), "
          f"{r.get('from_host', 0)} from it ({st.get('link_dropped', 0)} dropped); "
          f"buses listened to: {', '.join(r.get('subscribed', [])) or 'none'}")
    return 0


def run(args) -> int:
    if getattr(args, "action", None) in (None, "start"):
        return _start(args)
    return _client(args)


def _run_dir_arg(p) -> None:
    from ..sim.host import default_run_dir

    p.add_argument("--run-dir", default=str(default_run_dir()),
                   help="the control socket, state, key and the processes' output (default %(default)s)")


def _start_args(g) -> None:
    from ..sim.bridge import DEFAULT_PORT

    g.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help="the socketcand server's port on 127.0.0.1 (default %(default)s; 0: any free one)")
    g.add_argument("--no-bridge", action="store_true", help="no socketcand server (SocketCAN on the host only)")
    g.add_argument("--backend", choices=("auto", "host", "uml"), default="auto",
                   help="vcan of the host or inside a user-mode Linux (default: the host's where it has vcan)")
    g.add_argument("--relax", type=int, metavar="TICKS",
                   help="the controller's feedback and the drives' setpoint supervision, ticks "
                        "(default: 50 inside user-mode Linux, which misses 1 ms deadlines; the config's on the host)")
    g.add_argument("--operator-timeout", type=int, metavar="TICKS",
                   help="the controller's operator supervision (default: the config's)")
    g.add_argument("--mem", default="1G", help="memory of the user-mode Linux (default %(default)s)")
    g.add_argument("--key", help="the machine key (default: STEWART_KEY's file, else machine.key in the run dir)")
    g.add_argument("--build", help="the host build with sp_controller and hs_sim (default build/host-release)")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sim", help="the simulated platform in real time until stopped; its buses for python-can on the host",
        description="Starts the firmware's controller and the simulated hexapod in real time on vcan (the "
                    "host's, else inside a user-mode Linux) and keeps them running until Ctrl-C, SIGTERM or "
                    "`stewart sim stop`. The buses reach python-can programs on the host: SocketCAN where the "
                    "host has vcan, python-can's socketcand interface on 127.0.0.1 (-i socketcand -c vcan0). "
                    "`stewart sim inject LINE` plays scenario lines (loads, contacts, pushes, faults) at once; "
                    "`stewart sim status` reports the state and the real-time loop's deadline misses. "
                    "Guide: docs/guides/simulator.md.")
    _run_dir_arg(p)
    _start_args(p)
    acts = p.add_subparsers(dest="action", metavar="ACTION")
    _start_args(_run_dir_arg_parser(acts.add_parser("start", help="start it (the default)")))
    st = _run_dir_arg_parser(acts.add_parser("status", help="the running simulation's state and deadline misses"))
    st.add_argument("--json", action="store_true", help="as JSON")
    inj = _run_dir_arg_parser(acts.add_parser("inject", help="scenario lines, played at once"))
    inj.add_argument("lines", nargs="+", metavar="LINE", help="scenario lines (docs/reference/scenario.md)")
    _run_dir_arg_parser(acts.add_parser("stop", help="stop it (as Ctrl-C does)"))
    p.set_defaults(func=run)


def _run_dir_arg_parser(p):
    _run_dir_arg(p)
    return p
