# SPDX-License-Identifier: Apache-2.0
"""``stewart op``: the operator node on any bus python-can opens.

Every command waits for the controller's answer and exits 0 when it came,
1 when the controller refused (the reason on stderr), 2 for a usage, file
or bus problem, 3 when no answer came in time. docs/guides/operator.md.
"""

from __future__ import annotations

import json
import math
import signal
import sys
import time

from .. import busopts

AXES = ("x", "y", "z", "roll", "pitch", "yaw")
TICK_S = 0.001


def register(sub) -> None:
    p = sub.add_parser("op", help="operator node: engage, run, move, stream, stop, park, estop, "
                                  "reset, feedforward, force, guide, position, tare, status, watch, record")
    busopts.add_arguments(p, "ops")
    p.add_argument("--timeout", type=float, default=None, help="seconds to wait for the answer")
    p.add_argument("--key", metavar="FILE", help="the machine key (32 hex digits, mode 600) that signs the "
                   "commands that start or change motion (default: the file $STEWART_KEY names; "
                   "docs/explanation/security.md); STOP, PARK and ESTOP need none")
    ops = p.add_subparsers(dest="op", metavar="ACTION")
    import argparse

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--timeout", type=float, default=argparse.SUPPRESS,
                        help="seconds to wait for the answer")
    _add = ops.add_parser

    def add_parser(name, **kw):
        return _add(name, parents=[common], **kw)

    ops.add_parser = add_parser

    _add_motion_actions(ops)
    _add_stream_action(ops)
    _add_state_actions(ops)
    _add_force_actions(ops)
    _add_observer_actions(ops)
    _add_frame_actions(ops)
    for name in ("move", "stream", "force", "guide"):
        ops.choices[name].add_argument(
            "--frame", metavar="T[:W]", type=_frame_arg,
            help="select tool slot T (and work slot W) first (OP_FRAME): the pose or target is then of the "
                 "tool frame in the work frame (docs/reference/frames.md)")
    p.set_defaults(func=run)


def _frame_arg(text: str) -> tuple[int, int | None]:
    import argparse

    parts = text.split(":")
    try:
        vals = [int(v) for v in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected T or T:W, slot numbers 0..3") from None
    if len(vals) > 2 or not all(0 <= v <= 3 for v in vals):
        raise argparse.ArgumentTypeError(f"{text!r}: expected T or T:W, slot numbers 0..3")
    return vals[0], (vals[1] if len(vals) == 2 else None)


def _add_frame_actions(ops) -> None:
    """frame, reach."""
    fr = ops.add_parser("frame", help="select or set a tool or work frame (at rest: IDLE or READY)")
    fr.add_argument("kind", choices=("tool", "work"))
    fr.add_argument("verb", choices=("select", "set"))
    fr.add_argument("values", nargs="+", help="select: the slot 0..3; set: x y z (m) roll pitch yaw (rad), "
                    "into --slot (default 1)")
    fr.add_argument("--slot", type=int, default=1, choices=range(4), help="set: the slot to write (0..3)")
    fr.add_argument("--json", action="store_true")
    re_ = ops.add_parser("reach", help="can the tool frame reach this pose of the work frame? (nothing moves)")
    re_.add_argument("pose", nargs=6, type=float, metavar="V", help="x y z (m) roll pitch yaw (rad)")
    re_.add_argument("--json", action="store_true")


def _add_motion_actions(ops) -> None:
    """engage, run, move."""
    ops.add_parser("engage", help="engage: move from park to home (waits for READY)")
    r = ops.add_parser("run", help="the paper's trigonometric motion about home")
    r.add_argument("axis", choices=AXES)
    r.add_argument("amplitude", type=float, help="m (x, y, z) or rad")
    r.add_argument("frequency", type=float, help="Hz")
    r.add_argument("--fade", type=float, default=0.0, help="fade-in/out, s (0: the controller's 2 s)")
    r.add_argument("--duration", type=float, help="s of motion, then STOP (default: until Ctrl-C or "
                   "another operator stops it)")
    m = ops.add_parser("move", help="point-to-point move to a pose (waits for READY)")
    m.add_argument("pose", nargs=6, type=float, metavar="V", help="x y z (m) roll pitch yaw (rad)")
    m.add_argument("--relative", action="store_true", help="the pose is an offset from home")


def _add_stream_action(ops) -> None:
    """stream: poses from a CSV file or UDP."""
    s = ops.add_parser("stream", help="stream poses from a timestamped CSV file or UDP")
    src = s.add_mutually_exclusive_group(required=True)
    src.add_argument("--csv", metavar="FILE", help="CSV with t,x,y,z,roll,pitch,yaw")
    src.add_argument("--udp", metavar="HOST:PORT", help="receive datagrams (docs/guides/operator.md)")
    s.add_argument("--absolute", action="store_true", help="poses are absolute (default: offsets from home)")
    s.add_argument("--cueing", action="store_true", help="UDP telemetry (specific force, angular rate) "
                   "through the washout filter (stewart.cueing)")
    s.add_argument("--source-timeout", type=float, default=0.2, help="UDP: silent source after this many s")
    s.add_argument("--once", action="store_true", help="UDP: end when the source stops (default: wait "
                   "for it to resume until Ctrl-C)")
    s.add_argument("--wait-source", type=float, default=30.0, help="UDP: s to wait for the first datagram")
    s.add_argument("--stats", metavar="FILE", help="write the stream's figures as JSON")


def _add_state_actions(ops) -> None:
    """stop, park, estop, reset, feedforward."""
    ops.add_parser("stop", help="end the running motion smoothly (waits for READY)")
    ops.add_parser("park", help="park (waits for IDLE)")
    ops.add_parser("estop", help="emergency stop (waits for ESTOP)")
    ops.add_parser("reset", help="clear the faults and re-engage (waits for READY or IDLE)")
    f = ops.add_parser("feedforward", help="force feed-forward on or off (in IDLE or READY)")
    f.add_argument("switch", choices=("on", "off"))


def _add_force_actions(ops) -> None:
    """force, guide, position, tare."""
    fo = ops.add_parser("force", help="force control: push with a target wrench in the masked axes "
                        "(waits for FORCE)")
    fo.add_argument("axes", help="force-controlled axes of the base frame, joined by commas (z, x,z, ...) "
                    "or the mask 0..63")
    fo.add_argument("target", nargs=6, type=float, metavar="W",
                    help="fx fy fz (N) mx my mz (N m): what the platform is to exert, base frame, about o'")
    fo.add_argument("--update", action="store_true", help="in FORCE: only change the target (same axes)")
    fo.add_argument("--duration", type=float, help="s in force control, then POSITION (default: until "
                    "Ctrl-C, or until another operator or the controller ends it)")
    _param_args(fo, "the approach's: the speed in free space is target / damping")
    gu = ops.add_parser("guide", help="hand guiding in the masked axes (waits for GUIDE)")
    gu.add_argument("axes", help="axes joined by commas (x,y,z, ...) or the mask 0..63")
    gu.add_argument("--duration", type=float, help="s of hand guiding, then POSITION (default: until "
                    "Ctrl-C, or until another operator or the controller ends it)")
    _param_args(gu, "hand guiding's: a push F moves the platform at F / damping")
    ops.add_parser("position", help="leave force control smoothly (waits for position control)")
    ops.add_parser("tare", help="zero the force/torque sensor's bias (READY, position control, at rest)")


def _add_observer_actions(ops) -> None:
    """status, identify, watch, record."""
    st = ops.add_parser("status", help="one status reading")
    st.add_argument("--json", action="store_true")
    ident = ops.add_parser("identify", help="the controller's firmware version, port and protocol "
                           "(warns when its protocol is not this DBC)")
    ident.add_argument("--json", action="store_true")
    w = ops.add_parser("watch", help="live view (q or Ctrl-C quits)")
    w.add_argument("--rate", type=float, default=5.0, help="refreshes per second")
    w.add_argument("--duration", type=float, help="quit after this many s")
    w.add_argument("--heartbeat", action="store_true", help="send OP_HEARTBEAT: keep a running motion's "
                   "operator supervision satisfied while this watch runs (default: listen only)")
    rec = ops.add_parser("record", help="record the bus to a file: .log (candump), .blf, .asc, .mf4, ...")
    rec.add_argument("file")
    rec.add_argument("--duration", type=float, help="s (default: until Ctrl-C)")


def _param_args(parser, damping_help: str) -> None:
    """--mass/--damping/--stiffness: the admittance's parameters for the
    masked axes, sent (OP_FORCE_PARAMS) before force control starts; all
    three together (the message carries all three)."""
    parser.add_argument("--mass", type=float, metavar="KG", help="virtual mass, kg (kg m^2), 1..5000")
    parser.add_argument("--damping", type=float, metavar="NS_M",
                        help=f"free-space damping, N s/m (N m s/rad), 100..1e8; {damping_help}")
    parser.add_argument("--stiffness", type=float, metavar="N_M",
                        help="spring to the position reference, N/m (N m/rad), 0..1e7")


def _err(text: str) -> None:
    print(f"stewart op: {text}", file=sys.stderr)


class _Interrupt:
    """SIGINT / SIGTERM as a flag (the loops end cleanly)."""

    def __init__(self):
        self.hit = False
        self._old = {}

    def __enter__(self):
        for s in (signal.SIGINT, signal.SIGTERM):
            try:
                self._old[s] = signal.signal(s, self._on)
            except ValueError:  # not the main thread
                pass
        return self

    def _on(self, *_):
        self.hit = True

    def __exit__(self, *exc):
        for s, h in self._old.items():
            signal.signal(s, h)


def run(args) -> int:
    from ..busopts import BusError, open_bus
    from ..operator.node import OperatorNode, OpError
    from ..operator.sources import SourceError

    if not args.op:
        _err("an action is needed: engage, run, move, stream, stop, park, estop, reset, feedforward, "
             "force, guide, position, tare, frame, reach, status, identify, watch, record (stewart op --help)")
        return 2
    opts = busopts.options(args)
    # files first: a bad file is reported before the bus is touched
    try:
        prepared = _prepare(args)
    except SourceError as e:
        _err(str(e))
        return 2
    from .. import auth as au

    try:
        key = au.machine_key(args.key)
    except au.AuthError as e:
        _err(str(e))
        return 2
    try:
        bus = open_bus(opts)
    except BusError as e:
        _err(str(e))
        return 2
    if args.op == "record":
        return _record(bus, args)
    # observers send no heartbeat: a status poll or a watch screen must not
    # keep the operator link alive for a commanding process that died
    node = OperatorNode(bus, heartbeat=args.op not in OBSERVERS or getattr(args, "heartbeat", False), key=key,
                        monitor=args.op == "watch")
    try:
        node.start()
        if getattr(args, "frame", None) is not None:
            _select_frames(node, args.frame, args)
        return ACTIONS[args.op](node, args, prepared)
    except OpError as e:
        _err(str(e))
        return e.code
    except KeyboardInterrupt:
        _err("interrupted")
        return 130
    finally:
        node.close()


#: Actions that only listen: no OP_HEARTBEAT (docs/guides/operator.md).
OBSERVERS = ("status", "identify", "watch", "reach")


def _prepare(args):
    from ..operator.sources import SourceError, parse_host_port, read_pose_csv

    if args.op == "stream":
        if args.csv and args.cueing:
            raise SourceError("--cueing takes UDP telemetry (--udp)")
        if args.csv:
            return read_pose_csv(args.csv)
        return parse_host_port(args.udp)
    if args.op == "move" and not all(math.isfinite(v) for v in args.pose):
        raise SourceError("move: the pose must be finite numbers")
    if args.op == "run" and not (math.isfinite(args.amplitude) and math.isfinite(args.frequency)):
        raise SourceError("run: amplitude and frequency must be finite numbers")
    if args.op in ("force", "guide"):
        from .. import protocol as pr

        try:
            mask = pr.force_mask(args.axes)
        except ValueError as e:
            raise SourceError(f"{args.op}: {e}") from None
        if mask == 0:
            raise SourceError(f"{args.op}: no axis in the mask")
        target = [0.0] * 6 if args.op == "guide" else list(args.target)
        limit = 16383.96875  # OP_FORCE's range; the controller refuses above its own limits
        if not all(math.isfinite(v) and abs(v) <= limit for v in target):
            raise SourceError(f"{args.op}: the target must be finite, each |value| <= {limit:g} N or N m")
        params = (args.mass, args.damping, args.stiffness)
        if any(v is not None for v in params):
            if any(v is None for v in params):
                raise SourceError(f"{args.op}: --mass, --damping and --stiffness go together")
            if getattr(args, "update", False):
                raise SourceError(f"{args.op} --update: the parameters change only in position control")
            why = pr.force_params_check(*params)
            if why is not None:
                raise SourceError(f"{args.op}: {why}")
            return mask, target, params
        return mask, target, None
    return None


def _home() -> list[float]:
    from .. import config as cf
    from .. import resources

    return list(cf.load(resources.default_platform()).home)


def _report(ans, what: str = "") -> None:
    print(f"{ans.command}: {what or ans.status.state} ({ans.ticks} ticks after the command, "
          f"{ans.seconds * 1000:.0f} ms); {ans.status.line()}", flush=True)


def _t(args, default: float) -> float:
    return args.timeout if args.timeout is not None else default


# -- actions --------------------------------------------------------------------

def _engage(node, args, _):
    ans = node.command("ENGAGE", lambda s: s.state == "READY", timeout=_t(args, 60.0))
    _report(ans, "READY")
    return 0


def _state_is(*states):
    return lambda s: s.state in states


def _hold_running(node, until: float | None, intr) -> str:
    """Keeps the node (and its heartbeat) alive while RUNNING."""
    while not intr.hit:
        if until is not None and time.monotonic() >= until:
            return "duration"
        st = node.wait_status(timeout=2.0, after=node.status.seq)
        if st.state != "RUNNING":
            return st.state
        time.sleep(0.02)
    return "interrupt"


def _stop_and_wait(node, args):
    ans = node.command("STOP", lambda s: s.state != "RUNNING", timeout=_t(args, 60.0))
    return ans


def _run(node, args, _):
    with _Interrupt() as intr:
        ans = node.command("RUN_TRIG", _state_is("RUNNING"), timeout=_t(args, 5.0), axis=args.axis,
                           amplitude=args.amplitude, frequency=args.frequency, fade_time=args.fade)
        _report(ans)
        until = time.monotonic() + args.duration if args.duration is not None else None
        why = _hold_running(node, until, intr)
        if why in ("duration", "interrupt"):
            ans = _stop_and_wait(node, args)
            _report(ans, f"stopped ({why})")
            return 0
        st = node.status
        print(f"RUN_TRIG: the motion ended: {st.line()}")
        return 0 if st.state in ("READY", "PARKING", "IDLE") else 1


def _select_frames(node, frame, args) -> None:
    tool, work = frame
    fr = node.frame("SELECT", "TOOL", tool, timeout=_t(args, 10.0))
    if work is not None:
        fr = node.frame("SELECT", "WORK", work, timeout=_t(args, 10.0))
    print(f"frames: tool {fr['tool']}, work {fr['work']} (checksum 0x{fr['checksum']:08X})")


def _frames_line(fr: dict) -> str:
    what = "identity: poses of o' in the base frame" if fr["identity"] else "poses of the tool in the work frame"
    refused = ", ".join(f"{n} {v}" for n, v in fr["refused"].items() if v)
    return (f"frames: tool {fr['tool']}, work {fr['work']}, checksum 0x{fr['checksum']:08X} ({what})"
            + (f"; refused: {refused} (last: {fr['last_refusal']})" if refused else ""))


def _frame(node, args, _):
    kind = args.kind.upper()
    if args.verb == "select":
        if len(args.values) != 1 or not args.values[0].isdigit():
            _err("frame select: one slot number 0..3")
            return 2
        op, index, values = "SELECT", int(args.values[0]), None
    else:
        try:
            values = [float(v) for v in args.values]
        except ValueError:
            _err("frame set: six numbers x y z roll pitch yaw")
            return 2
        if len(values) != 6:
            _err("frame set: six numbers x y z roll pitch yaw")
            return 2
        op, index = "SET", args.slot
    fr = node.frame(op, kind, index, values, timeout=_t(args, 10.0))
    print(json.dumps(fr) if args.json else _frames_line(fr))
    return 0


def _reach(node, args, _):
    a = node.reach(list(args.pose), timeout=_t(args, 5.0))
    if args.json:
        print(json.dumps(a))
    else:
        forces = " ".join(f"{f / 1000:.2f}" for f in a["force"])
        if a["verdict"] == "REACHABLE":
            print(f"reach: REACHABLE; cylinder forces at rest {forces} kN")
        elif a["verdict"] == "NOT_FINITE":
            print("reach: refused: a value is not a finite number")
        elif a["verdict"] == "WORKSPACE":
            axis = ("x", "y", "z", "roll", "pitch", "yaw")[a["which"]]
            unit = "mm" if a["which"] < 3 else "mrad"
            print(f"reach: UNREACHABLE: beyond the workspace in {axis} by {a['excess'] * 1000:.3f} {unit}")
        elif a["verdict"] in ("LEG_SHORT", "LEG_LONG"):
            how = "too short" if a["verdict"] == "LEG_SHORT" else "too long"
            print(f"reach: UNREACHABLE: leg {a['which'] + 1} {how} by {a['excess'] * 1000:.3f} mm; "
                  f"cylinder forces at rest {forces} kN")
        else:
            print(f"reach: UNREACHABLE: {a['verdict']}")
    return {"REACHABLE": 0, "NOT_FINITE": 2}.get(a["verdict"], 1)


def _move(node, args, _):
    pose = list(args.pose)
    if args.relative:
        pose = [h + d for h, d in zip(_home(), pose)]
    # twice: the controller's E2E check may drop a new sender's first frame
    node.send_target(pose)
    node.wait_status(timeout=2.0, after=node.status.seq if node.status else 0)
    node.send_target(pose)
    with _Interrupt() as intr:
        ans = node.command("MOVE_TO", lambda s: s.state != "READY" or intr.hit, timeout=_t(args, 5.0))
        if ans.status.state != "RUNNING":
            _report(ans)
            return 0 if ans.status.state == "READY" else 1
        st = node.wait_status(after=ans.status.seq)
        end = time.monotonic() + _t(args, 120.0)
        while st.state == "RUNNING" and not intr.hit and time.monotonic() < end:
            st = node.wait_status(after=st.seq)
        if st.state == "RUNNING":
            ans = _stop_and_wait(node, args)
            _report(ans, "stopped")
            return 130 if intr.hit else 3
        if getattr(args, "frame", None) is not None and node.frames and not node.frames["identity"]:
            print(f"MOVE_TO: {st.state} (tool pose target in the work frame); {st.line()}")
            return 0 if st.state == "READY" else 1
        err = max(abs(a - b) for a, b in zip(st.pose, pose))
        print(f"MOVE_TO: {st.state}, largest |estimate - target| {err * 1000:.3f} mm/mrad; {st.line()}")
        return 0 if st.state == "READY" else 1


def _simple(command, done, default_timeout, precheck=None):
    def action(node, args, _):
        st = node.wait_status(timeout=2.0)
        if precheck is not None:
            msg = precheck(st)
            if msg:
                print(f"{command}: {msg}; {st.line()}")
                return 0
        ans = node.command(command, done, timeout=_t(args, default_timeout), sync=(command != "ESTOP"))
        _report(ans)
        return 0
    return action


def _stop_pre(st):
    if st.state != "RUNNING":
        return f"nothing to stop (the controller is {st.state})"
    return None


def _reset_done(s):
    return s.state in ("READY", "IDLE") and not s.faults


def _feedforward(node, args, _):
    on = args.switch == "on"
    ans = node.command("SET_FEEDFORWARD", lambda s: s.feedforward == on, timeout=_t(args, 2.0),
                       option=1 if on else 0)
    _report(ans, f"feed-forward {args.switch}")
    return 0


def _send_force_twice(node, mask, target):
    """OP_FORCE twice with a status between: the controller's E2E check may
    drop a new sender's first frame (a second identical one is harmless)."""
    node.send_force(mask, target)
    node.wait_status(timeout=2.0, after=node.status.seq if node.status else 0)
    node.send_force(mask, target)


def _send_params(node, args, mask, params) -> int:
    """OP_FORCE_PARAMS (twice, as OP_FORCE: the E2E check may drop a new
    sender's first frame), then 20 statuses for a refusal (the controller
    takes them in position control only)."""
    if params is None:
        return 0
    from ..operator.node import Refused

    mode = "FORCE" if args.op == "force" else "GUIDE"
    st = node.wait_status(timeout=2.0)
    node.send_force_params(mask, mode, *params)
    node.wait_status(timeout=2.0, after=node.status.seq)
    mark = node._mark()
    sent = node.send_force_params(mask, mode, *params)
    try:
        node.wait_for("FORCE_PARAMS", lambda s: True, _t(args, 5.0), mark, st, sent, settle=20)
    except Refused as e:
        why = node.auth_reason()  # signed as OP_FORCE: a rejection for the code says why
        if why is not None:
            _err(f"{args.op}: admittance parameters rejected: {why}")
        elif node.status.force_mode != "OFF":
            _err(f"{args.op}: admittance parameters refused (force control is {node.status.force_mode}: "
                 "they change only in position control)")
        else:
            _err(f"{args.op}: admittance parameters {e}")
        return 1
    print(f"{mode} parameters: mass {params[0]:g}, damping {params[1]:g}, stiffness {params[2]:g} "
          f"(axes mask {mask})")
    return 0


def _force(node, args, prepared):
    mask, target, params = prepared
    if _send_params(node, args, mask, params):
        return 1
    st = node.wait_status(timeout=2.0)
    if args.update:
        if st.force_mode != "FORCE":
            print(f"force --update: force control is {st.force_mode}, not FORCE; {st.line()}")
            return 1
        from ..operator.node import Refused

        mark = node._mark()  # keeps every status from here on
        node.send_force(mask, target)
        node.wait_status(timeout=2.0, after=node.status.seq)
        # the first may meet the E2E check (see _send_force_twice); the second
        # is the one answered for: a slow (niced) operator may send it many
        # ticks after the first, so its statuses are counted from its own send
        sent = node.send_force(mask, target)
        try:
            # a refusal comes within a tick or two of the frame; 20 statuses after it, none came
            ans = node.wait_for("FORCE", lambda s: True, _t(args, 5.0), mark, st, sent, settle=20)
        except Refused as e:
            _err(str(e).replace("FORCE refused", "FORCE update refused"))
            return 1
        st = ans.status
        print(f"FORCE: target updated to {' '.join(f'{v:g}' for v in target)}; {st.line()}")
        return 0
    _send_force_twice(node, mask, target)
    return _hold_force(node, args, "FORCE")


def _hold_force(node, args, command):
    """Enters FORCE or GUIDE, then keeps the node (and its heartbeat: the
    controller lets go of a silent operator) alive while force control is
    on: --duration s, Ctrl-C (then POSITION), or until another operator or
    the controller ends it."""
    with _Interrupt() as intr:
        ans = node.command(command, lambda s: s.force_mode == command, timeout=_t(args, 5.0))
        _report(ans, command)
        until = time.monotonic() + args.duration if args.duration is not None else None
        st = ans.status
        while not intr.hit and (until is None or time.monotonic() < until):
            st = node.wait_status(timeout=2.0, after=node.status.seq)
            if st.force_mode != command:
                break
            time.sleep(0.02)
        if st.force_mode == command:
            ans = node.command("POSITION", lambda s: s.force_mode == "OFF", timeout=_t(args, 30.0))
            _report(ans, f"position control ({'interrupt' if intr.hit else 'duration'})")
            return 0
        print(f"{command}: force control ended: {st.line()}", flush=True)
        return 0 if not st.faults else 1


def _guide(node, args, prepared):
    mask, target, params = prepared
    if _send_params(node, args, mask, params):
        return 1
    node.wait_status(timeout=2.0)
    _send_force_twice(node, mask, target)
    return _hold_force(node, args, "GUIDE")


def _position(node, args, _):
    st = node.wait_status(timeout=2.0)
    if st.force_mode == "OFF":
        print(f"POSITION: nothing to leave (position control already); {st.line()}")
        return 0
    ans = node.command("POSITION", lambda s: s.force_mode == "OFF", timeout=_t(args, 30.0))
    _report(ans, "position control")
    return 0


def _tare(node, args, _):
    ans = node.command("TARE", lambda s: True, timeout=_t(args, 5.0))
    _report(ans, "taring (the controller averages the sensor's readings at rest)")
    return 0


def _status(node, args, _):
    """One status; the active frames too when the controller reports them
    (CTRL_FRAMES comes every 100 ms: waited for up to 3 s). --json: one
    object, its "frames" null for a controller without frames."""
    from ..operator.node import OpError

    st = node.wait_status(timeout=_t(args, 2.0))
    try:
        fr = node.wait_frames(timeout=3.0)
    except OpError:
        fr = None
    if args.json:
        print(json.dumps({"tick": st.tick, "state": st.state, "faults": st.faults,
                          "drive_mode": st.drive_mode, "feedforward": st.feedforward,
                          "estimate_valid": st.estimate_valid, "pose": st.pose,
                          "force_mode": st.force_mode, "contact": st.contact,
                          "drives_starting": st.drives_starting, "force_unmeasured": st.force_unmeasured,
                          "frames": fr}))
        return 0
    print(st.line())
    if fr is not None:
        print(_frames_line(fr))
    return 0


def _identify(node, args, _):
    """The controller's CTRL_IDENTITY; its ProtocolHash against this DBC's."""
    from .. import __version__
    from .. import protocol as pr

    ident = node.identify(timeout=_t(args, 2.0))
    ours = pr.dbc_hash(node.proto.dbc_path)
    same = ident["protocol_hash"] == ours
    if args.json:
        print(json.dumps({**ident, "tools_protocol_hash": ours, "same_protocol": same, "tools_version": __version__}))
    else:
        print(f"firmware {ident['version']} ({ident['port']}), protocol {ident['protocol_hash']:08x}; "
              f"tools {__version__}, protocol {ours:08x}")
    if not same:
        _err(f"warning: the controller speaks another protocol ({ident['protocol_hash']:08x}) than this "
             f"DBC ({ours:08x}, {node.proto.dbc_path}): frames may be misread")
    return 0


# -- stream ---------------------------------------------------------------------

class _Pacer:
    """1 kHz absolute deadlines; records each send's lateness against its
    deadline. A send more than RESYNC_S late (the process was not scheduled)
    starts the grid again from now rather than sending a burst to catch up;
    such ticks are counted (`resyncs`)."""

    RESYNC_S = 0.010

    def __init__(self):
        self.t0 = time.monotonic()
        self.origin = self.t0
        self.k = 0
        self.lateness: list[float] = []
        self.resyncs = 0

    def wait(self) -> float:
        """Sleeps to the next deadline; returns the seconds since the start."""
        self.k += 1
        due = self.t0 + self.k * TICK_S
        now = time.monotonic()
        if due - now > 0:
            time.sleep(due - now)
            now = time.monotonic()
        self.lateness.append(now - due)
        if now - due > self.RESYNC_S:
            self.resyncs += 1
            self.t0 = now - self.k * TICK_S
        return now - self.origin


def _jitter(pacer) -> dict:
    lateness = pacer.lateness
    if not lateness:
        return {"median_us": 0.0, "p99_us": 0.0, "max_us": 0.0, "resyncs": 0, "ticks": 0}
    v = sorted(abs(x) for x in lateness)
    return {"median_us": v[len(v) // 2] * 1e6, "p99_us": v[min(len(v) - 1, int(0.99 * len(v)))] * 1e6,
            "max_us": v[-1] * 1e6, "resyncs": pacer.resyncs, "ticks": pacer.k}


def _start_stream(node, args):
    ans = node.command("STREAM", _state_is("RUNNING"), timeout=_t(args, 5.0))
    _report(ans)
    return ans


def _stream(node, args, prepared):
    from ..operator.sources import PoseTrack, UdpSource

    home = _home()
    offset = [0.0] * 6 if args.absolute else home
    stats = {"frames_sent": 0, "send_errors": 0, "targets_refused": 0, "events": []}
    with _Interrupt() as intr:
        if isinstance(prepared, PoseTrack):
            rc = _stream_csv(node, args, prepared, offset, stats, intr)
        else:
            host, port = prepared
            src = UdpSource(host, port, cueing=args.cueing)
            print(f"stream: listening on UDP {src.address[0]}:{src.address[1]}"
                  + (" (cueing telemetry)" if args.cueing else ""), flush=True)
            try:
                rc = _stream_udp(node, args, src, offset, stats, intr)
            finally:
                src.close()
                stats["udp"] = vars(src.counters)
                print("stream: " + src.counters.line()
                      + (f" (last bad: {src.counters.last_bad})" if src.counters.bad else ""))
    print(f"stream: frames sent {stats['frames_sent']}, send errors {stats['send_errors']}, "
          f"targets refused {stats['targets_refused']}, send-time jitter median "
          f"{stats.get('jitter', {}).get('median_us', 0):.0f} us, p99 "
          f"{stats.get('jitter', {}).get('p99_us', 0):.0f} us, late ticks (grid restarted) "
          f"{stats.get('jitter', {}).get('resyncs', 0)}")
    if args.stats:
        with open(args.stats, "w") as f:
            json.dump(stats, f, indent=1)
    return rc


def _send_pose(node, pose, stats) -> None:
    from ..operator.node import OpError

    try:
        node.send_target(pose)
        stats["frames_sent"] += 1
    except OpError:
        stats["send_errors"] += 1


def _count_refused(node, seen: int, stats) -> int:
    st = node.status
    if st is not None and st.seq != seen and st.cmd_rejected:
        stats["targets_refused"] += 1
    return st.seq if st is not None else seen


def _finish_stream(node, args, stats, why: str) -> int:
    stats["events"].append(why)
    st = node.status
    if st is not None and st.state == "RUNNING":
        ans = _stop_and_wait(node, args)
        _report(ans, f"settled back to home ({why})")
        return 0 if ans.status.state == "READY" else 1
    print(f"stream: ended ({why}); {st.line() if st else 'no status'}")
    return 0 if st is not None and st.state == "READY" else 1


def _stream_csv(node, args, track, offset, stats, intr) -> int:
    first = [o + v for o, v in zip(offset, track.at(track.t[0]))]
    node.send_target(first)  # the E2E resynchronisation frame
    _start_stream(node, args)
    pacer = _Pacer()
    seen = 0
    t_end = track.duration
    while not intr.hit:
        t = pacer.wait()
        if t > t_end:
            break
        _send_pose(node, [o + v for o, v in zip(offset, track.at(track.t[0] + t))], stats)
        seen = _count_refused(node, seen, stats)
        if node.status is not None and node.status.state != "RUNNING":
            stats["jitter"] = _jitter(pacer)
            print(f"stream: the controller left RUNNING: {node.status.line()}")
            return 1
    stats["jitter"] = _jitter(pacer)
    return _finish_stream(node, args, stats, "interrupted" if intr.hit else "end-of-file")


def _washout():
    try:
        from .. import cueing  # written alongside; optional on this branch
    except ImportError:
        return None
    return cueing.Washout(dt=TICK_S)


def _stream_udp(node, args, src, offset, stats, intr) -> int:
    washout = None
    if args.cueing:
        washout = _washout()
        if washout is None:
            from ..operator.node import OpError

            raise OpError("--cueing needs the module stewart.cueing (the washout filter), not installed here")
    deadline = time.monotonic() + args.wait_source
    latest = None
    while latest is None:
        if intr.hit:
            return 130
        if time.monotonic() > deadline:
            print(f"stream: no datagram within {args.wait_source:g} s")
            return 3
        latest = src.poll()
        time.sleep(0.002)
    rc = 0
    while True:
        node.send_target(_udp_pose(latest, washout, offset))  # resynchronisation frame
        _start_stream(node, args)
        stats["events"].append("source-started")
        pacer = _Pacer()
        last_rx = time.monotonic()
        seen = 0
        reason = "interrupted"
        while not intr.hit:
            pacer.wait()
            v = src.poll()
            now = time.monotonic()
            if v is not None:
                latest = v
                last_rx = now
            elif now - last_rx > args.source_timeout:
                reason = "source-lost"
                print(f"stream: event source-lost: no datagram for {args.source_timeout:g} s, "
                      "settling back to home", flush=True)
                break
            _send_pose(node, _udp_pose(latest, washout, offset), stats)
            seen = _count_refused(node, seen, stats)
            if node.status is not None and node.status.state != "RUNNING":
                stats["jitter"] = _jitter(pacer)
                print(f"stream: the controller left RUNNING: {node.status.line()}")
                return 1
        stats["jitter"] = _jitter(pacer)
        rc = _finish_stream(node, args, stats, reason)
        if reason != "source-lost" or args.once or rc != 0:
            return rc
        latest = None
        while latest is None and not intr.hit:
            latest = src.poll()
            time.sleep(0.002)
        if intr.hit:
            return rc
        print("stream: event source-resumed", flush=True)
        stats["events"].append("source-resumed")
        if washout is not None:
            washout = _washout()


def _udp_pose(values, washout, offset):
    if washout is not None:  # the washout filter's poses are absolute (home at rest)
        return [float(v) for v in washout.step(values[:3], values[3:])]
    return [o + v for o, v in zip(offset, values)]


# -- watch ----------------------------------------------------------------------

def _watch(node, args, _):
    import os
    import select

    period = 1.0 / max(0.5, min(args.rate, 50.0))
    tty = sys.stdin.isatty() and sys.stdout.isatty()
    old = None
    if tty:
        import termios
        import tty as ttymod

        fd = sys.stdin.fileno()
        old = termios.tcgetattr(fd)
        ttymod.setcbreak(fd)
    end = time.monotonic() + args.duration if args.duration else None
    last_frames: dict = {}
    last_t = time.monotonic()
    try:
        with _Interrupt() as intr:
            while not intr.hit and (end is None or time.monotonic() < end):
                now = time.monotonic()
                frames = dict(node.counters.frames)
                rates = {k: (v - last_frames.get(k, 0)) / max(1e-3, now - last_t) for k, v in frames.items()}
                last_frames, last_t = frames, now
                text = _watch_text(node, rates)
                if tty:
                    sys.stdout.write("\x1b[H\x1b[2J" + text + "\n(q quits)\n")
                else:
                    sys.stdout.write(text + "\n\n")
                sys.stdout.flush()
                if tty:
                    r, _, _ = select.select([sys.stdin], [], [], period)
                    if r and os.read(sys.stdin.fileno(), 1) in (b"q", b"Q"):
                        break
                else:
                    time.sleep(period)
    finally:
        if old is not None:
            import termios

            termios.tcsetattr(sys.stdin.fileno(), termios.TCSADRAIN, old)
    return 0


def _fmt(v, scale=1.0, width=9, prec=3):
    return " ".join(f"{x * scale:{width}.{prec}f}" for x in v)


def _watch_text(node, rates) -> str:
    st, mon, wr, c = node.status, node.monitor, node.wrench, node.counters
    lines = [f"stewart op watch  {time.strftime('%H:%M:%S')}"]
    if st is None:
        lines.append("no CTRL_STATUS received yet")
    else:
        lines.append(f"state {st.state:<9} faults {','.join(st.faults) or 'none':<20} drives {st.drive_mode:<6} "
                     f"feed-forward {'on' if st.feedforward else 'off'}  tick {st.tick}")
        lines.append("                       x mm      y mm      z mm   roll mrad pitch mrad  yaw mrad")
        lines.append("estimated pose   " + _fmt(st.pose, 1000.0) + ("" if st.estimate_valid else "  (invalid)"))
    if mon is not None:
        lines.append("reference pose   " + _fmt(mon["reference"], 1000.0))
        lines.append("leg setpoint mm  " + _fmt(mon["length_sp"], 1000.0, 9, 2))
        lines.append("leg force ff kN  " + _fmt(mon["force_ff"], 0.001, 9, 3))
    if wr is not None:
        lines.append("ext. wrench N/Nm " + _fmt(wr["wrench"], 1.0, 9, 1) + ("" if wr["valid"] else "  (invalid)"))
    lines.append("frames/s: " + ", ".join(f"{k} {v:.0f}" for k, v in sorted(rates.items())))
    bad = ", ".join(f"{k} {v}" for k, v in sorted(c.bad.items())) or "none"
    lines.append(f"lost {c.lost}, rejected: {bad}, error frames {c.error_frames}, "
                 f"sent {c.sent} (heartbeats {c.heartbeats}), send errors {c.send_errors}")
    return "\n".join(lines)


# -- record ---------------------------------------------------------------------

def _record(bus, args) -> int:
    import can

    try:
        writer = can.Logger(args.file)
    except (ImportError, NotImplementedError) as e:
        _err(f"{args.file}: the writer for this format is not installed ({e})")
        bus.shutdown()
        return 2
    except (ValueError, OSError) as e:
        _err(f"{args.file}: {e}")
        bus.shutdown()
        return 2
    n = 0
    end = time.monotonic() + args.duration if args.duration else None
    try:
        with _Interrupt() as intr:
            while not intr.hit and (end is None or time.monotonic() < end):
                msg = bus.recv(timeout=0.1)
                if msg is not None:
                    writer.on_message_received(msg)
                    n += 1
    except (can.CanError, OSError) as e:
        _err(f"receiving: {e}")
        return 2
    finally:
        writer.stop()
        bus.shutdown()
    print(f"record: {n} frames to {args.file}")
    return 0


ACTIONS = {
    "engage": _engage,
    "run": _run,
    "move": _move,
    "stream": _stream,
    "stop": _simple("STOP", lambda s: s.state != "RUNNING", 60.0, _stop_pre),
    "park": _simple("PARK", _state_is("IDLE"), 120.0),
    "estop": _simple("ESTOP", _state_is("STOPPING", "ESTOP"), 2.0),
    "reset": _simple("RESET", _reset_done, 60.0),
    "feedforward": _feedforward,
    "force": _force,
    "guide": _guide,
    "position": _position,
    "tare": _tare,
    "status": _status,
    "identify": _identify,
    "watch": _watch,
    "frame": _frame,
    "reach": _reach,
}
