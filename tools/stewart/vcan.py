# SPDX-License-Identifier: Apache-2.0
"""Run a command with virtual CAN buses (vcan0..vcanN-1) up, on any Linux.

Two back ends:

``host``
    The host kernel has vcan: the interfaces already exist, or
    ``ip link add dev vcanK type vcan`` works (root). The command runs
    directly; interfaces this module created are deleted afterwards.

``uml``
    The host kernel has no CAN. Debian's ``user-mode-linux`` boots a Linux
    kernel as an ordinary process with the host's file system as its root
    (hostfs). A generated init script (PID 1) mounts /proc, /sys and a tmpfs
    on /dev/shm, brings up the loopback, loads can, can-raw, can-dev and vcan
    from ``/usr/lib/uml/modules/<UML kernel version>/kernel``, creates the
    buses, then runs the command in the caller's working directory with the
    caller's environment. The command's stdout and stderr leave the UML on
    two consoles of their own (tty1, tty2) and are relayed live; kernel and
    boot messages go to a separate log that is shown only when the UML fails.
    The command's exit status comes back through a status file in a
    temporary directory (hostfs), so it cannot be confused with a crash.

Common to both: stdin of the command is /dev/null; a time limit kills the
whole process group (a UML is many host processes, all in one session that
this module creates); nothing is left running afterwards.

Exit status of :func:`run`: the command's status (128+N when it died of
signal N), 124 when the time limit was reached, 125 when the buses could not
be set up (message on stderr), 127 when the command was not found (host
back end; inside UML the shell reports 127 itself).
"""

from __future__ import annotations

import ctypes
import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from . import resources, uml

#: Exit statuses of our own (the same conventions as timeout(1) and env(1)).
EXIT_TIMEOUT = 124
EXIT_SETUP = 125
EXIT_NOT_FOUND = 127

#: MTU of a vcan interface: classic CAN frames / CAN FD frames.
MTU_CLASSIC = 16
MTU_FD = 72

#: Modules loaded inside the UML, in dependency order (path under kernel/,
#: without the .ko suffix, which may carry a compression extension).
UML_MODULES = (
    "net/can/can",
    "net/can/can-raw",
    "drivers/net/can/dev/can-dev",
    "drivers/net/can/vcan",
)
#: Loaded when present; python-can's periodic sending uses the BCM socket.
UML_OPTIONAL_MODULES = ("net/can/can-bcm",)
UML_BINARY = uml.SYSTEM_BINARY
#: Host programs the init script runs inside the UML (through hostfs).
UML_TOOLS = ("sh", "mount", "insmod", "ip", "stty", "cat")
INSTALL_HINT = ("install the Debian packages user-mode-linux, kmod and iproute2 "
                "(apt-get install user-mode-linux kmod iproute2)")
#: What to do when no back end works (after the list of what was tried).
FIX_HINT = ("To fix it: run scripts/setup.sh (it installs Debian's user-mode-linux and, "
            "where that kernel panics on this CPU, fetches a newer one into .cache/uml), "
            "or `stewart vcan --install-uml`; on a Linux whose kernel has vcan, "
            "`modprobe vcan` as root lets the buses run on the host.")

#: Environment variables not copied into the UML: set by the shell or by us.
_ENV_SKIP = {"PWD", "OLDPWD", "SHLVL", "_"}
_ENV_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: Characters allowed in paths that go on the UML kernel command line.
_SAFE_PATH = re.compile(r"^[A-Za-z0-9_./+-]+$")
_MEM = re.compile(r"^([0-9]+)([KMG]?)$", re.IGNORECASE)

#: Grace period between SIGTERM and SIGKILL for the host back end (s).
_KILL_GRACE = 5.0
_POLL = 0.01


class VcanError(RuntimeError):
    """The buses cannot be provided: the message says why and what to do."""


# ---------------------------------------------------------------- helpers


def interface_names(count: int) -> list[str]:
    """``["vcan0", ..., "vcan<count-1>"]``; ``count`` must be 1..64."""
    if not 1 <= count <= 64:
        raise VcanError(f"bus count must be 1..64, not {count}")
    return [f"vcan{i}" for i in range(count)]


def parse_mem(text: str) -> int:
    """Bytes of a UML memory size such as ``512M`` (suffix K, M or G)."""
    m = _MEM.match(text.strip())
    if not m:
        raise VcanError(f"bad memory size {text!r}: use e.g. 512M")
    scale = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30}[m.group(2).upper()]
    value = int(m.group(1)) * scale
    if value < (64 << 20):
        raise VcanError(f"memory size {text!r} is below 64M: the UML would not boot")
    return value


def _ip_binary() -> str | None:
    return shutil.which("ip") or next(
        (p for p in ("/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip") if os.access(p, os.X_OK)),
        None)


def _ip(*args: str) -> subprocess.CompletedProcess:
    exe = _ip_binary()
    if exe is None:
        raise VcanError("the ip command is missing: install iproute2")
    return subprocess.run([exe, *args], stdin=subprocess.DEVNULL, capture_output=True,
                          text=True, check=False)


def _host_link_mtu(name: str) -> int | None:
    """MTU of host interface ``name``, None when it does not exist."""
    try:
        return int(Path(f"/sys/class/net/{name}/mtu").read_text().strip())
    except (OSError, ValueError):
        return None


def _uml_problem(k: uml.Kernel) -> str | None:
    """Why kernel ``k`` cannot be booted at all (missing files or programs),
    or None."""
    if not k.exists():
        if k.kind == "system":
            return f"{UML_BINARY} is not installed: {INSTALL_HINT}"
        return f"{k.binary} is not there (`stewart vcan --install-uml` fetches it)"
    if uml.module_dir(k) is None:
        return f"no vcan module under {k.modules}: {INSTALL_HINT}"
    path = "/usr/sbin:/usr/bin:/sbin:/bin"
    missing = [t for t in UML_TOOLS if shutil.which(t, path=path) is None]
    if missing:
        return f"programs needed inside the UML are missing: {', '.join(missing)}: {INSTALL_HINT}"
    return None


def _host_problem(count: int) -> str | None:
    """Why the host back end cannot work, or None when it can.

    True when vcan0..vcan<count-1> all exist, or when a probe interface can
    be created (and is deleted again).
    """
    names = interface_names(count)
    if all(_host_link_mtu(n) is not None for n in names):
        return None
    if _ip_binary() is None:
        return "the ip command is missing (iproute2)"
    probe = f"svprobe{os.getpid() % 100000}"
    r = _ip("link", "add", "dev", probe, "type", "vcan")
    if r.returncode != 0:
        return f"the host cannot create vcan interfaces ({r.stderr.strip() or 'ip failed'})"
    _ip("link", "del", "dev", probe)
    return None


# ------------------------------------------------------ process handling


def _wait_exit(pid: int, deadline: float | None) -> bool:
    """Wait until ``pid`` (our child) has exited, without reaping it (so its
    pid, which is also the process-group id, cannot be reused yet). True when
    it exited before ``deadline`` (time.monotonic())."""
    while True:
        try:
            info = os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:
            return True
        if info is not None:
            return True
        if deadline is not None and time.monotonic() >= deadline:
            return False
        time.sleep(_POLL)


def _killpg(pgid: int, sig: int) -> None:
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _reap_group(pgid: int, deadline: float) -> None:
    """Reap our children in process group ``pgid`` (killed already) until
    none is left or ``deadline`` (time.monotonic()) passes."""
    while True:
        try:
            pid, _ = os.waitpid(-pgid, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            if time.monotonic() >= deadline:
                return
            time.sleep(_POLL)


class _Subreaper:
    """While active, orphans of our descendants are re-parented to this
    process (prctl PR_SET_CHILD_SUBREAPER) rather than to PID 1, which in
    some containers never reaps them: killed UML helpers would stay zombies.
    Best effort: a no-op where prctl is unavailable."""

    SET, GET = 36, 37

    def __enter__(self) -> "_Subreaper":
        self.prctl = None
        try:
            prctl = ctypes.CDLL(None, use_errno=True).prctl
            old = ctypes.c_int(0)
            if (prctl(self.GET, ctypes.byref(old), 0, 0, 0) == 0 and old.value == 0
                    and prctl(self.SET, ctypes.c_ulong(1), 0, 0, 0) == 0):
                self.prctl = prctl
        except (OSError, AttributeError):
            pass
        return self

    def __exit__(self, *exc: object) -> None:
        if self.prctl is not None:
            self.prctl(self.SET, ctypes.c_ulong(0), 0, 0, 0)


def _status_of(returncode: int) -> int:
    """A Popen returncode as a shell exit status (signal N -> 128+N)."""
    return 128 - returncode if returncode < 0 else returncode


class _Interrupted(Exception):
    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class _Signals:
    """Turns SIGINT/SIGTERM/SIGHUP into :class:`_Interrupted` while active
    (main thread only; elsewhere a no-op) so the group is always cleaned."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

    def __enter__(self) -> "_Signals":
        self.old: dict[int, object] = {}
        if threading.current_thread() is threading.main_thread():
            for s in self.SIGNALS:
                self.old[s] = signal.signal(s, self._raise)
        return self

    @staticmethod
    def _raise(signum: int, frame: object) -> None:
        del frame
        raise _Interrupted(signum)

    def __exit__(self, *exc: object) -> None:
        for s, h in self.old.items():
            signal.signal(s, h)  # type: ignore[arg-type]


def _writer(stream) -> Callable[[bytes], None]:
    """A function writing raw bytes to ``stream`` at once (binary buffer when
    it has one, else decoded text), ignoring a closed reader."""
    buf = getattr(stream, "buffer", None)
    try:
        stream.flush()  # what was printed before comes first
    except (ValueError, OSError):
        pass

    def write(data: bytes) -> None:
        try:
            if buf is not None:
                buf.write(data)
                buf.flush()
            else:
                stream.write(data.decode("utf-8", "replace"))
                stream.flush()
        except (BrokenPipeError, ValueError, OSError):
            pass

    return write


def _pump(fd: int, sink: Callable[[bytes], None]) -> None:
    """Copy from pipe ``fd`` to ``sink`` until end of file; closes ``fd``."""
    try:
        while True:
            try:
                data = os.read(fd, 65536)
            except InterruptedError:
                continue
            except OSError:
                break
            if not data:
                break
            sink(data)
    finally:
        os.close(fd)


# ------------------------------------------------------------------- host


def _run_host(argv: Sequence[str], count: int, fd: bool, timeout: float, env: dict,
              verbose: bool = False) -> int:
    created: list[str] = []
    restore_mtu: dict[str, int] = {}
    want = MTU_FD if fd else MTU_CLASSIC
    try:
        for name in interface_names(count):
            mtu = _host_link_mtu(name)
            if mtu is None:
                r = _ip("link", "add", "dev", name, "type", "vcan")
                if r.returncode != 0:
                    raise VcanError(f"cannot create {name}: {r.stderr.strip()}")
                created.append(name)
                steps = [("link", "set", "dev", name, "mtu", str(want))]
            elif fd and mtu != MTU_FD:
                restore_mtu[name] = mtu
                steps = [("link", "set", "dev", name, "down"),
                         ("link", "set", "dev", name, "mtu", str(MTU_FD))]
            else:
                steps = []
            steps.append(("link", "set", "dev", name, "up"))
            for step in steps:
                r = _ip(*step)
                if r.returncode != 0:
                    raise VcanError(f"ip {' '.join(step)}: {r.stderr.strip()}")
        env = dict(env, STEWART_VCAN="host")
        with _Subreaper():
            try:
                proc = subprocess.Popen(list(argv), stdin=subprocess.DEVNULL, env=env,
                                        start_new_session=True)
            except FileNotFoundError:
                print(f"stewart vcan: {argv[0]}: command not found", file=sys.stderr)
                return EXIT_NOT_FOUND
            except PermissionError as e:
                print(f"stewart vcan: {argv[0]}: {e.strerror}", file=sys.stderr)
                return 126
            if verbose:
                print(f"stewart vcan: host: command pid {proc.pid} (process group {proc.pid}); "
                      f"created {' '.join(created) or 'no interface'}", file=sys.stderr)
            return _supervise(proc, timeout, grace=_KILL_GRACE)[0]
    finally:
        for name in created:
            _ip("link", "del", "dev", name)
        for name, mtu in restore_mtu.items():
            _ip("link", "set", "dev", name, "down")
            _ip("link", "set", "dev", name, "mtu", str(mtu))
            _ip("link", "set", "dev", name, "up")


def _supervise(proc: subprocess.Popen, timeout: float, grace: float) -> tuple[int, bool]:
    """Wait for ``proc`` (leader of its own session) with a time limit, then
    kill whatever is left of its process group. Returns (exit status, True)
    when it ended by itself, else (EXIT_TIMEOUT or 128+signal, False) when
    the limit or a signal to us ended it."""
    deadline = time.monotonic() + timeout
    status: int | None = None
    try:
        with _Signals():
            if not _wait_exit(proc.pid, deadline):
                print(f"stewart vcan: time limit of {timeout:g} s reached: killing the command",
                      file=sys.stderr)
                status = EXIT_TIMEOUT
                if grace > 0:
                    _killpg(proc.pid, signal.SIGTERM)
                    _wait_exit(proc.pid, time.monotonic() + grace)
    except _Interrupted as e:
        status = 128 + e.signum
        if grace > 0:
            _killpg(proc.pid, e.signum)
            _wait_exit(proc.pid, time.monotonic() + grace)
    finally:
        # The leader is a zombie or still running: its pid (= group id)
        # cannot have been reused, so this reaches only our processes.
        _killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        _reap_group(proc.pid, time.monotonic() + 10.0)
    if status is None:
        return _status_of(proc.returncode), True
    return status, False


# -------------------------------------------------------------------- UML


def _init_script(argv: Sequence[str], names: list[str], mtu: int, cwd: str,
                 env: dict, state: str, module_dir: Path, tty_out: bool = False,
                 tty_err: bool = False) -> str:
    q = shlex.quote
    lines = [
        "#!/bin/sh",
        "# Generated by stewart vcan: PID 1 of a user-mode Linux.",
        "PATH=/usr/sbin:/usr/bin:/sbin:/bin",
        "export PATH",
        f"S={q(state)}",
        "halt() {",
        "  echo \"$1\" > /proc/exitcode 2>/dev/null",
        "  poweroff -f >/dev/null 2>&1",
        "  echo o > /proc/sysrq-trigger 2>/dev/null",
        "  while :; do sleep 1; done",
        "}",
        "fail() {",
        "  echo \"stewart vcan (uml): $*\" >&2",
        "  echo \"setup-failed $*\" > \"$S/status\"",
        f"  halt {EXIT_SETUP}",
        "}",
        "mount -t proc proc /proc || fail 'mount /proc'",
        "mount -t sysfs sysfs /sys || fail 'mount /sys'",
        "[ -d /dev/shm ] || mkdir -p /dev/shm",
        "mount -t tmpfs -o mode=1777 tmpfs /dev/shm || fail 'mount /dev/shm'",
        # The UML kernel's own version (not the host's).
        "read V < /proc/sys/kernel/osrelease",
        f"K={q(str(module_dir.parent.parent))}/$V/kernel",
        "load() { for f in \"$K/$1\".ko*; do insmod \"$f\"; return $?; done; return 1; }",
    ]
    lines += [f"load {q(m)} || fail 'insmod {m}'" for m in UML_MODULES]
    lines += [f"load {q(m)} 2>/dev/null" for m in UML_OPTIONAL_MODULES]
    # One ip process for all links (each process start costs ~40 ms in UML).
    batch = ["link set dev lo up"]
    for n in names:
        batch += [f"link add dev {n} type vcan", f"link set dev {n} mtu {mtu}",
                  f"link set dev {n} up"]
    lines += ["ip -batch - <<'EOF' || fail 'ip: loopback and vcan set-up'", *batch, "EOF"]
    # Raw output on the command's consoles (else LF becomes CR LF).
    lines += [
        "stty -opost < /dev/tty1 || fail 'stty tty1'",
        "stty -opost < /dev/tty2 || fail 'stty tty2'",
        "O=/dev/tty1 E=/dev/tty2 co= ce=",
    ]
    # Where the caller's stream is not a terminal, the command gets a pipe
    # (as it would on the host: no colours, block buffering), copied by cat.
    if not tty_out:
        lines += ["mkfifo /dev/shm/.stewart-out || fail mkfifo",
                  "cat /dev/shm/.stewart-out > /dev/tty1 & co=$!",
                  "O=/dev/shm/.stewart-out"]
    if not tty_err:
        lines += ["mkfifo /dev/shm/.stewart-err || fail mkfifo",
                  "cat /dev/shm/.stewart-err > /dev/tty2 & ce=$!",
                  "E=/dev/shm/.stewart-err"]
    lines += [
        "read up idle < /proc/uptime",
        "echo \"$up $V\" > \"$S/booted\"",
        "(",
        "  unset HOME TERM",
    ]
    for k, v in env.items():
        lines.append(f"  export {k}={q(v)}")
    lines += [
        f"  export PWD={q(cwd)}",
        f"  cd {q(cwd)} || exit {EXIT_SETUP}",
        "  exec " + " ".join(q(a) for a in argv),
        ") < /dev/null > \"$O\" 2> \"$E\"",
        "rc=$?",
        # Whatever the command left running dies now (so the copies see the
        # end of their pipes); the copies drain, then the UML powers off.
        "for p in /proc/[0-9]*; do",
        "  p=${p#/proc/}",
        "  case \" 1 $co $ce \" in *\" $p \"*) ;; *) kill -9 \"$p\" 2>/dev/null;; esac",
        "done",
        "[ -z \"$co$ce\" ] || wait $co $ce",
        "echo \"rc $rc\" > \"$S/status\"",
        "halt $rc",
        "",
    ]
    return "\n".join(lines)


#: Which host CPU the user-mode Linux runs on: unset, the last one this
#: process may use; a number, that one; ``none``, any (the host scheduler's
#: choice).
PIN_ENV = "STEWART_UML_CPU"


def pin_cpu() -> int | None:
    """The host CPU to hold the user-mode Linux to, or None: the last one
    allowed that no other running UML is held to (else the least taken).

    The UML kernel and the host process of each of its processes hand the
    CPU to each other (ptrace) at every system call and switch. Left to the
    host's scheduler they were spread over both cores of an idle 2-core
    machine, and each hand-over crossed cores: ``stewart sim`` then missed
    5-14 % of its 1 ms deadlines and relayed 2,700 of the buses' 13,500
    frames a second. Held to one core, the same run missed 0.2-0.4 % and
    relayed them all (3 December 2026)."""
    want = os.environ.get(PIN_ENV, "").strip()
    if want.lower() == "none":
        return None
    try:
        allowed = sorted(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return None
    if want:
        try:
            cpu = int(want)
        except ValueError:
            raise VcanError(f"{PIN_ENV}={want!r}: a CPU number or none") from None
        if cpu not in allowed:
            raise VcanError(f"{PIN_ENV}={cpu}: not one of this process's CPUs {allowed}")
        return cpu
    if len(allowed) < 2:
        return None
    taken = _uml_cpus()  # another run's UML (the bus tests beside `stewart sim`): another core
    return min(reversed(allowed), key=lambda c: taken.count(c))


def _uml_cpus() -> list[int]:
    """The host CPUs that running linux.uml processes are held to, one
    entry a process held to a single CPU."""
    out: list[int] = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            if not (d / "comm").read_text().startswith("linux.uml"):
                continue
            cpus = os.sched_getaffinity(int(d.name))
        except OSError:
            continue
        if len(cpus) == 1:
            out.append(next(iter(cpus)))
    return out


def pin_prefix() -> list[str]:
    """The command's prefix that holds linux.uml (and the processes it
    starts) to :func:`pin_cpu`'s CPU: util-linux's taskset, which execs it
    (the process keeps its pid and command line)."""
    cpu = pin_cpu()
    if cpu is None or shutil.which("taskset") is None:
        return []
    return ["taskset", "-c", str(cpu)]


def _uml_env(mem: int, scratch: str) -> dict:
    """Environment of the linux.uml process itself. UML backs its memory
    with a file in $TMPDIR, else /dev/shm: use /dev/shm when it has room,
    else the scratch directory (a small /dev/shm, e.g. in containers, would
    make the UML die of SIGBUS)."""
    env = {k: v for k, v in os.environ.items() if k not in ("TMPDIR", "TMP", "TEMP")}
    try:
        shm_free = shutil.disk_usage("/dev/shm").free
    except OSError:
        shm_free = 0
    env["TMPDIR"] = "/dev/shm" if shm_free >= mem + (64 << 20) else scratch
    return env


#: vm.max_map_count the UML needs: it maps guest pages into its host process
#: one by one, and a guest using a few hundred MB (numpy decoding a 30 s CAN
#: log) passes the kernel's default of 65530 maps and dies ("UML ran out of
#: memory on the host side").
MAP_COUNT_NEEDED = 262144


def _raise_map_count(path: str = "/proc/sys/vm/max_map_count") -> None:
    """Raises vm.max_map_count to MAP_COUNT_NEEDED when it is lower and we
    may (root); otherwise leaves it and says so once on stderr."""
    try:
        current = int(Path(path).read_text().strip())
    except (OSError, ValueError):
        return
    if current >= MAP_COUNT_NEEDED:
        return
    try:
        Path(path).write_text(f"{MAP_COUNT_NEEDED}\n")
    except OSError:
        print(f"stewart vcan: vm.max_map_count is {current}; a guest using more than about 200 MB "
              f"needs {MAP_COUNT_NEEDED} (sysctl -w vm.max_map_count={MAP_COUNT_NEEDED} as root)",
              file=sys.stderr)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def _make_state_dir() -> str:
    """A private temporary directory whose path is safe on the kernel
    command line (no spaces or quotes)."""
    for base in (None, "/tmp"):
        d = tempfile.mkdtemp(prefix="stewart-vcan-", dir=base)
        if _SAFE_PATH.match(d):
            return d
        os.rmdir(d)
    raise VcanError("cannot make a temporary directory with a plain path")


@dataclass
class _Boot:
    """What one boot of a UML left behind."""

    status: int  #: linux.uml's exit status (or ours: 124, 128+N)
    ended: bool  #: it ended by itself (not the time limit or a signal)
    state: list[str]  #: words of the init script's status file
    log: bytes  #: the kernel's console
    booted: list[str]  #: seconds from kernel start to the buses, UML release
    wall: float


def _boot_uml(k: uml.Kernel, argv: Sequence[str], count: int, fd: bool, timeout: float,
              env: dict, mem: int, out: Callable[[bytes], None],
              err: Callable[[bytes], None], verbose: bool = False, quiet: bool = True,
              consoles: Sequence[tuple[int, int]] = (),
              on_start: Callable[[int], None] | None = None) -> _Boot:
    """Boots kernel ``k`` with the buses up and runs ``argv`` in it; its
    stdout and stderr go to ``out`` and ``err`` as they come. ``quiet``:
    the kernel logs errors only (else all its boot messages). ``consoles``:
    more consoles, (host fd read, host fd written) each, /dev/tty3 on
    inside (``stewart sim``'s link). ``on_start(pgid)`` is called once
    linux.uml runs: its process group, for a caller that stops it."""
    names = interface_names(count)
    _raise_map_count()
    state = _make_state_dir()
    log: list[bytes] = []
    try:
        inner_env = {k2: v for k2, v in env.items()
                     if _ENV_NAME.match(k2) and k2 not in _ENV_SKIP}
        inner_env.setdefault("TMPDIR", "/tmp")
        inner_env["STEWART_VCAN"] = "uml"
        init = Path(state) / "init"
        modules = uml.module_dir(k)
        if modules is None:
            raise VcanError(f"no vcan module under {k.modules}")
        init.write_text(_init_script(argv, names, MTU_FD if fd else MTU_CLASSIC, os.getcwd(),
                                     inner_env, state, modules, _isatty(sys.stdout),
                                     _isatty(sys.stderr)),
                        encoding="utf-8", errors="surrogateescape")
        init.chmod(0o700)

        out_r, out_w = os.pipe()
        err_r, err_w = os.pipe()
        log_r, log_w = os.pipe()
        cmd = [
            str(k.binary),
            *(("quiet", "loglevel=3") if quiet else ()), f"mem={mem // (1 << 20)}M",
            "root=/dev/root", "rootfstype=hostfs", "hostfs=/", "rw",
            f"init={init}", f"uml_dir={state}",
            "con=null", "con0=null,fd:1", f"con1=null,fd:{out_w}", f"con2=null,fd:{err_w}",
            *(f"con{3 + i}=fd:{r},fd:{w}" for i, (r, w) in enumerate(consoles)),
        ]
        cmd = [*pin_prefix(), *cmd]
        t0 = time.monotonic()
        with _Subreaper():
            try:
                proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log_w,
                                        stderr=log_w,
                                        pass_fds=(out_w, err_w, *(f for c in consoles for f in c)),
                                        env=_uml_env(mem, state), start_new_session=True)
            except OSError:
                for r in (out_r, err_r, log_r):
                    os.close(r)
                raise
            finally:
                for w in (out_w, err_w, log_w):
                    os.close(w)
            if verbose:
                print(f"stewart vcan: uml: linux.uml pid {proc.pid} (process group {proc.pid})",
                      file=sys.stderr)
            if on_start is not None:
                on_start(proc.pid)
            pumps = [
                threading.Thread(target=_pump, args=(out_r, out), daemon=True),
                threading.Thread(target=_pump, args=(err_r, err), daemon=True),
                threading.Thread(target=_pump, args=(log_r, log.append), daemon=True),
            ]
            for p in pumps:
                p.start()
            status, ended = _supervise(proc, timeout, grace=0.0)
        for p in pumps:
            p.join(timeout=60.0)
        words = [] if not (Path(state) / "status").exists() else \
            (Path(state) / "status").read_text().split()
        booted = [] if not (Path(state) / "booted").exists() else \
            (Path(state) / "booted").read_text().split()
        return _Boot(status, ended, words, b"".join(log), booted, time.monotonic() - t0)
    finally:
        shutil.rmtree(state, ignore_errors=True)


def _save_log(data: bytes, name: str) -> Path:
    """Writes a kernel log to a file a message can name."""
    path = uml.log_file(name)
    try:
        path.write_bytes(data.replace(b"\r\n", b"\n"))
    except OSError:
        pass
    return path


def _probe_boot(k: uml.Kernel) -> uml.Probe:
    """Boots ``k`` once with one FD bus and runs ``true`` in it."""
    sink: list[bytes] = []
    try:
        b = _boot_uml(k, ["true"], 1, True, 60.0, {"PATH": "/usr/bin:/bin"}, 256 << 20,
                      sink.append, sink.append, quiet=False)
    except (OSError, VcanError) as e:
        return uml.Probe(uml.MISSING, f"cannot be started ({e})")
    verdict, reason = uml.classify(b.state, b.log.decode("utf-8", "replace"), b.ended, b.status)
    log = _save_log(b.log, f"uml-{k.kind}-probe.log")
    if verdict == uml.PANICS and uml.cpu_has_amx():
        reason += " on this CPU with AMX"
    return uml.Probe(verdict, reason, b.booted[1] if len(b.booted) > 1 else "", str(log),
                     round(b.wall, 2))


@dataclass
class Choice:
    """The back end :func:`run` uses, and why."""

    backend: str  #: "host" or "uml"
    kernel: uml.Kernel | None = None  #: the UML kernel (uml back end)
    probe: uml.Probe | None = None  #: its probe
    cached: bool = False  #: the probe's verdict came from the cache
    tried: list[str] = field(default_factory=list)  #: what was tried before, one line each

    def describe(self) -> list[str]:
        """Lines for a person: the back end, its kernel, where from, why."""
        if self.backend == "host":
            return ["back end: host (the host kernel's own vcan)",
                    f"kernel: Linux {os.uname().release} (the host's)"]
        assert self.kernel is not None and self.probe is not None
        lines = ["back end: uml (a user-mode Linux kernel with vcan, run as a process)",
                 f"kernel: Linux {self.probe.version or '?'} ({self.kernel.binary})",
                 f"from: {self.kernel.origin}",
                 f"probe: {self.probe.reason}, {self.probe.seconds:.1f} s to boot"
                 + (" (cached verdict)" if self.cached else "")]
        lines += [f"why not: {t}" for t in self.tried]
        return lines


def choose(count: int = 3, backend: str = "auto", uml_kernel: str | None = None,
           refresh: bool = False, boot: Callable[[uml.Kernel], uml.Probe] | None = None) -> Choice:
    """Picks the back end: the host's vcan where it works (``auto`` or
    ``host``), else the first UML kernel (``uml_kernel``, else $STEWART_UML,
    else the system's then the cache's) whose probe boots with vcan. Probes
    are cached per host (:mod:`stewart.uml`). Raises :class:`VcanError` with
    a paragraph naming everything tried and what to do."""
    if backend not in ("auto", "host", "uml"):
        raise VcanError(f"unknown back end {backend!r}: use auto, host or uml")
    tried: list[str] = []
    if backend in ("auto", "host"):
        host = _host_problem(count)
        if host is None:
            return Choice("host")
        if backend == "host":
            raise VcanError(f"host: {host}")
        tried.append(f"the host kernel: {host}")
    try:
        kernels = uml.candidates(uml_kernel)
    except uml.UmlError as e:
        raise VcanError(str(e)) from None
    for k in kernels:
        problem = _uml_problem(k)
        if problem:
            tried.append(f"{k.origin}: {problem}")
            continue
        p, cached = uml.probe(k, boot or _probe_boot, refresh)
        if p.verdict == uml.OK:
            return Choice("uml", k, p, cached, tried)
        tried.append(f"{k.origin}: {p.reason}" + (f"; kernel log in {p.log}" if p.log else ""))
    raise VcanError("no virtual CAN bus can be set up on this host. Tried:\n"
                    + "\n".join(f"  - {t}" for t in tried) + "\n" + FIX_HINT)


def _run_uml(argv: Sequence[str], count: int, fd: bool, timeout: float, env: dict,
             mem: int, verbose: bool, k: uml.Kernel, consoles: Sequence[tuple[int, int]] = (),
             on_start: Callable[[int], None] | None = None) -> int:
    problem = _uml_problem(k)
    if problem:
        raise VcanError(problem)
    b = _boot_uml(k, argv, count, fd, timeout, env, mem, _writer(sys.stdout),
                  _writer(sys.stderr), verbose, consoles=consoles, on_start=on_start)
    if not b.ended:
        return b.status
    if len(b.state) == 2 and b.state[0] == "rc" and b.state[1].isdigit():
        rc = int(b.state[1])
        if verbose:
            print(f"stewart vcan: uml: buses up {b.booted[0] if b.booted else '?'} s after "
                  f"kernel start; {b.wall:.2f} s in all; exit status {rc}", file=sys.stderr)
            _show_log(b.log)
        return rc
    _, reason = uml.classify(b.state, b.log.decode("utf-8", "replace"), b.ended, b.status)
    path = _save_log(b.log, f"uml-run-{os.getpid()}.log")
    print(f"stewart vcan: the user-mode Linux ({k.binary}) stopped before the command ended: "
          f"it {reason}; kernel log in {path}", file=sys.stderr)
    if verbose:
        _show_log(b.log)
    return EXIT_SETUP


def _show_log(log: bytes) -> None:
    text = log.decode("utf-8", "replace").replace("\r\n", "\n")
    for line in text.splitlines()[-60:]:
        print(f"  | {line}", file=sys.stderr)


# -------------------------------------------------------------------- API


def run(argv: Sequence[str], count: int = 3, fd: bool = True, timeout: float = 600,
        backend: str = "auto", mem: str = "512M", verbose: bool = False,
        uml_kernel: str | None = None) -> int:
    """Run ``argv`` with vcan0..vcan<count-1> up; return its exit status.

    ``fd``: MTU 72 (CAN FD) instead of 16. ``timeout``: seconds for
    everything (boot included), after which all is killed and 124 returned.
    ``backend``: ``"auto"``, ``"host"`` or ``"uml"``. ``mem``: UML memory.
    ``uml_kernel``: ``"auto"``, ``"system"`` or ``"cache"`` (default
    $STEWART_UML, else auto; see :func:`choose`).
    The command inherits the working directory and environment; its stdin is
    /dev/null; its stdout/stderr go to ours as they come. Set-up failures
    print a message and return 125 (``VcanError`` is raised only for bad
    arguments and when no back end exists).
    """
    argv = list(argv)
    if not argv:
        raise VcanError("no command given")
    if timeout <= 0:
        raise VcanError("the time limit must be positive")
    interface_names(count)
    mem_bytes = parse_mem(mem)
    env = dict(os.environ)
    if backend == "host":
        try:
            return _run_host(argv, count, fd, timeout, env, verbose)
        except VcanError as e:
            print(f"stewart vcan: host: {e}", file=sys.stderr)
            return EXIT_SETUP
    c = choose(count, backend, uml_kernel)
    if verbose:
        for line in c.describe():
            print(f"stewart vcan: {line}", file=sys.stderr)
    if c.backend == "host":
        try:
            return _run_host(argv, count, fd, timeout, env, verbose)
        except VcanError as e:
            print(f"stewart vcan: host: {e}", file=sys.stderr)
            return EXIT_SETUP
    assert c.kernel is not None
    return _run_uml(argv, count, fd, timeout, env, mem_bytes, verbose, c.kernel)


def _short(k: uml.Kernel) -> str:
    """A kernel in a few words: ``Debian's 7.2um1 UML from .cache/uml``."""
    if k.kind == "system":
        return k.origin
    try:
        src = json.loads((k.binary.parents[2] / "SOURCE.json").read_text())
        where = k.binary.parents[2]
        root = resources.checkout()
        if root is not None and where.is_relative_to(root):
            where = where.relative_to(root)
        return f"Debian {src['suite']}'s {src['user-mode-linux']} UML from {where}"
    except (OSError, ValueError, KeyError, TypeError):
        return k.origin


def ensure(count: int = 3, uml_kernel: str | None = None) -> str:
    """Makes sure a back end works here, fetching a newer UML kernel into
    the cache (:func:`stewart.uml.install_cache`) when the host has no vcan
    and no installed UML boots, or when ``cache`` is asked for. Returns one
    line saying what is used and why; raises :class:`VcanError` when nothing
    works even then."""
    try:
        want = uml.wanted(uml_kernel)
    except uml.UmlError as e:
        raise VcanError(str(e)) from None
    fetched = False
    if want == "cache" and not uml.cached_kernel().exists():
        _install()
        fetched = True
    try:
        c = choose(count, "auto", want)
    except VcanError:
        if want != "auto" or uml.cached_kernel().exists():
            raise
        _install()
        fetched = True
        c = choose(count, "auto", want)
    if c.backend == "host":
        return "the host kernel has vcan: the buses run on the host"
    assert c.kernel is not None
    how = "fetched now" if fetched else "already there"
    if c.kernel.kind == "system":
        return f"{_short(c.kernel)} boots on this CPU: using it"
    if want == "cache":
        return f"STEWART_UML=cache: using {_short(c.kernel)} ({how})"
    before = "; ".join(t for t in c.tried if "host kernel" not in t)
    if uml.cpu_has_amx() and "panics" in before:
        before = "this CPU has AMX: Debian's installed UML panics here"
    return f"{before}; using {_short(c.kernel)} ({how})"


def _install() -> None:
    try:
        uml.install_cache()
    except (uml.UmlError, OSError) as e:
        raise VcanError(f"cannot fetch a newer UML kernel into {uml.cache_dir()}: {e}") from None


def backend_available(count: int = 3) -> str:
    """The back end :func:`run` would use: ``"host"`` or ``"uml"``.

    Raises :class:`VcanError` naming what was tried and what to install
    when neither works.
    """
    return choose(count).backend


def host_has_vcan() -> bool:
    """True when the host back end works for three buses (used by tests)."""
    return _host_problem(3) is None


def run_uml(argv: Sequence[str], consoles: Sequence[tuple[int, int]] = (),
            on_start: Callable[[int], None] | None = None, count: int = 3, fd: bool = True,
            timeout: float = 600, mem: str = "512M", uml_kernel: str | None = None) -> int:
    """As :func:`run` on the uml back end (forced), with more consoles:
    ``consoles`` (host fd read, host fd written) pairs are /dev/tty3.. inside
    (``stewart sim`` relays its buses over one); ``on_start(pgid)`` is told
    linux.uml's process group once it runs, so that a caller can stop it.
    The caller's signal handlers stay in force when called from a thread
    other than the main one."""
    c = choose(count, "uml", uml_kernel)
    assert c.kernel is not None
    return _run_uml(list(argv), count, fd, timeout, dict(os.environ), parse_mem(mem), False, c.kernel,
                    consoles, on_start)
