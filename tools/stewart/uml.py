# SPDX-License-Identifier: Apache-2.0
"""Which user-mode Linux (UML) kernel boots on this host, and where to get one.

``stewart vcan`` needs a Linux kernel with vcan. Where the host's kernel has
none, a UML kernel runs as an ordinary process. Two kernels are known:

``system``
    Debian's ``user-mode-linux`` package as installed (``linux.uml`` on the
    PATH, modules under ``/usr/lib/uml/modules``). Bookworm's 6.1 boots on
    most CPUs, but panics as init starts on CPUs with AMX (the host's XSAVE
    area is larger than the UML's fixed buffer: ``ptrace set fp regs
    failed``). Trixie's 6.12 does the same.

``cache``
    A newer UML from Debian's package registry (sid's ``user-mode-linux``,
    7.2 when this was written, which sizes that buffer from the host), with
    the glibc it needs (>= 2.38; bookworm has 2.36), unpacked by
    :func:`install_cache` into a directory of our own (the checkout's
    ``.cache/uml``, ignored by git) and pointed at that glibc with patchelf.
    No system package is changed.

A kernel is *probed* by booting it once with vcan set up (about 1-2 s) and
the verdict is cached per host (``~/.cache/stewart/uml-probe.json``), keyed
by the kernel binary (path, size, modification time), its modules, the CPU
(vendor, model, flags) and the host kernel's release: a change of any of
them probes again.

The environment variable ``STEWART_UML`` (or ``stewart vcan --uml-kernel``)
chooses: ``auto`` (default: the system's where it boots, else the cache's),
``system`` or ``cache``.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from . import resources

#: Kinds of kernels, in the order ``auto`` tries them.
KINDS = ("system", "cache")
CHOICES = ("auto", *KINDS)

SYSTEM_BINARY = "linux.uml"
SYSTEM_MODULES = Path("/usr/lib/uml/modules")
#: The Debian suite and packages the cache is made from.
CACHE_SUITE = "sid"
CACHE_PACKAGES = ("user-mode-linux", "libc6")
CACHE_MIRROR = "http://deb.debian.org/debian"
CACHE_KEYRING = "/usr/share/keyrings/debian-archive-keyring.gpg"
#: Module folders kept in the cache (the rest of the 160 MB tree is not used).
CACHE_MODULE_DIRS = ("net/can", "drivers/net/can")

#: Probe verdicts.
OK, MISSING, PANICS, NO_VCAN, FAILED = "ok", "missing", "panics", "no-vcan", "failed"

#: Kernel-log lines that mean the UML kernel died on this CPU.
_PANIC_MARKS = ("Kernel panic", "ptrace set fp regs failed", "Attempted to kill init")


class UmlError(RuntimeError):
    """A UML kernel cannot be fetched or installed: the message says why."""


@dataclass(frozen=True)
class Kernel:
    """A UML kernel: the binary to run and its module tree."""

    kind: str  #: "system" or "cache"
    binary: Path  #: the linux.uml to run (relative: not found on the PATH)
    modules: Path  #: holds <kernel version>/kernel/...
    origin: str  #: where it comes from, in words

    def exists(self) -> bool:
        b = self.binary
        return b.is_absolute() and b.is_file() and os.access(b, os.X_OK)


@dataclass
class Probe:
    """What booting a kernel once showed."""

    verdict: str  #: OK, MISSING, PANICS, NO_VCAN or FAILED
    reason: str  #: one line for a person
    version: str = ""  #: the UML kernel's release when it booted
    log: str = ""  #: file holding the kernel log of the probe ("" if none)
    seconds: float = 0.0  #: wall time of the boot


# ------------------------------------------------------------ the kernels


def user_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "stewart"


def cache_dir() -> Path:
    """Where the newer UML is unpacked: ``$STEWART_UML_CACHE``, else the
    checkout's ``.cache/uml``, else ``~/.cache/stewart/uml``."""
    env = os.environ.get("STEWART_UML_CACHE")
    if env:
        return Path(env).resolve()
    root = resources.checkout()
    return root / ".cache" / "uml" if root else user_cache_dir() / "uml"


def _dpkg_version(package: str) -> str:
    try:
        r = subprocess.run(["dpkg-query", "-W", "-f=${Version}", package], capture_output=True,
                           text=True, check=False, stdin=subprocess.DEVNULL)
    except OSError:
        return ""
    return r.stdout.strip() if r.returncode == 0 else ""


def system_kernel() -> Kernel:
    found = shutil.which(SYSTEM_BINARY)
    version = _dpkg_version("user-mode-linux") if found else ""
    origin = (f"Debian's user-mode-linux {version} as installed" if version
              else "the system's linux.uml")
    return Kernel("system", Path(found or SYSTEM_BINARY), SYSTEM_MODULES, origin)


def cached_kernel(root: Path | None = None) -> Kernel:
    root = root or cache_dir()
    origin = f"the project's UML cache {root}"
    try:
        src = json.loads((root / "SOURCE.json").read_text())
        origin = (f"Debian {src['suite']}'s user-mode-linux {src['user-mode-linux']} "
                  f"(glibc {src['libc6']}) unpacked in {root}")
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return Kernel("cache", root / "usr" / "bin" / SYSTEM_BINARY,
                  root / "usr" / "lib" / "uml" / "modules", origin)


def kernel(kind: str) -> Kernel:
    if kind == "system":
        return system_kernel()
    if kind == "cache":
        return cached_kernel()
    raise UmlError(f"unknown UML kernel {kind!r}: use one of {', '.join(CHOICES)}")


def wanted(choice: str | None = None) -> str:
    """The user's choice: the argument, else $STEWART_UML, else ``auto``."""
    choice = choice or os.environ.get("STEWART_UML") or "auto"
    if choice not in CHOICES:
        raise UmlError(f"STEWART_UML / --uml-kernel must be one of {', '.join(CHOICES)}, "
                       f"not {choice!r}")
    return choice


def candidates(choice: str | None = None) -> list[Kernel]:
    c = wanted(choice)
    return [kernel(k) for k in (KINDS if c == "auto" else (c,))]


# ---------------------------------------------------------- the verdicts


def cpu_has_amx(cpuinfo: str | None = None) -> bool:
    text = cpuinfo if cpuinfo is not None else _read("/proc/cpuinfo")
    return "amx_tile" in text.split()


def classify(state: list[str], log: str, ended: bool, exit_status: int) -> tuple[str, str]:
    """The verdict of one boot from what it left: the words of the init
    script's status file (``rc N`` or ``setup-failed ...``), the kernel log,
    whether it ended by itself and linux.uml's exit status."""
    if len(state) == 2 and state[0] == "rc":
        if state[1] == "0":
            return OK, "boots and brings up vcan"
        return FAILED, f"booted, but the probe command exited with {state[1]}"
    if state[:1] == ["setup-failed"]:
        what = " ".join(state[1:])
        if "insmod" in what:
            return NO_VCAN, f"boots, but cannot load the CAN modules ({what})"
        return FAILED, f"boots, but its set-up failed ({what})"
    lines = [ln.strip() for ln in log.replace("\r", "").splitlines() if ln.strip()]
    if not ended:
        return FAILED, "did not finish booting in time"
    if any(m in ln for ln in lines for m in _PANIC_MARKS):
        why = next((ln for ln in lines if "ptrace set fp regs failed" in ln), None)
        why = why or next(ln for ln in lines if any(m in ln for m in _PANIC_MARKS))
        return PANICS, f"panics as init starts ({why})"
    last = lines[-1] if lines else "no kernel output"
    return FAILED, f"stopped with exit status {exit_status} before init ran ({last})"


def static_problem(k: Kernel) -> str | None:
    """What is missing before a boot is worth trying, or None."""
    if not k.exists():
        return f"{k.binary} is not there"
    if module_dir(k) is None:
        return f"no vcan module under {k.modules}"
    return None


def module_dir(k: Kernel) -> Path | None:
    """The newest ``<version>/kernel`` under the kernel's modules with vcan."""
    if not k.modules.is_dir():
        return None
    found = sorted(d / "kernel" for d in k.modules.iterdir()
                   if list((d / "kernel" / "drivers/net/can").glob("vcan.ko*")))
    return found[-1] if found else None


# --------------------------------------------------------------- the cache


def _read(path: str) -> str:
    try:
        return Path(path).read_text(errors="replace")
    except OSError:
        return ""


def cpu_signature(cpuinfo: str | None = None) -> str:
    """Vendor, model and flags of the first CPU: what decides whether a UML
    kernel boots here."""
    text = cpuinfo if cpuinfo is not None else _read("/proc/cpuinfo")
    keep = ("vendor_id", "cpu family", "model", "model name", "flags")
    first = text.split("\n\n", 1)[0]
    fields = [ln.split(":", 1)[1].strip() for ln in first.splitlines()
              if ":" in ln and ln.split(":", 1)[0].strip() in keep]
    return hashlib.sha256("\n".join(fields).encode()).hexdigest()[:16]


def probe_key(k: Kernel, cpu: str | None = None, host_release: str | None = None) -> str:
    """The cache key of a probe of ``k`` on this host."""
    try:
        st = k.binary.stat()
        stamp = f"{k.binary.resolve()}:{st.st_size}:{st.st_mtime_ns}"
    except OSError:
        stamp = f"{k.binary}:absent"
    mods = module_dir(k)
    parts = [k.kind, stamp, str(mods.parent) if mods else "no-modules",
             cpu or cpu_signature(), host_release or os.uname().release]
    return hashlib.sha256("|".join(parts).encode()).hexdigest()[:24]


def _probe_cache_file() -> Path:
    return user_cache_dir() / "uml-probe.json"


def _load_probes() -> dict:
    try:
        data = json.loads(_probe_cache_file().read_text())
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def _store_probe(key: str, p: Probe) -> None:
    data = _load_probes()
    data[key] = dict(asdict(p), when=time.time())
    # keep the 16 newest: a host sees few kernels
    data = dict(sorted(data.items(), key=lambda kv: kv[1].get("when", 0))[-16:])
    path = _probe_cache_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(data, indent=1))
        tmp.replace(path)
    except OSError:
        pass  # no cache: the next call probes again


def probe(k: Kernel, boot, refresh: bool = False) -> tuple[Probe, bool]:
    """The verdict on ``k`` and whether it came from the cache. ``boot(k)``
    boots it once (the vcan module provides it) and returns a :class:`Probe`."""
    problem = static_problem(k)
    if problem:
        return Probe(MISSING, problem), False
    key = probe_key(k)
    if not refresh:
        hit = _load_probes().get(key)
        if isinstance(hit, dict):
            try:
                return Probe(hit["verdict"], hit["reason"], hit.get("version", ""),
                             hit.get("log", ""), hit.get("seconds", 0.0)), True
            except KeyError:
                pass
    result = boot(k)
    if result.verdict != FAILED or "in time" not in result.reason:
        _store_probe(key, result)  # a time-out on a loaded host is not a verdict
    return result, False


def log_file(name: str) -> Path:
    """A file for a kernel log that a message can name."""
    d = user_cache_dir() / "logs"
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError:
        d = Path(tempfile.gettempdir())
    return d / name


# ------------------------------------------------------- fetching a kernel


def _apt_options(work: Path) -> list[str]:
    return ["-o", f"Dir::Etc::SourceList={work / 'sources.list'}",
            "-o", "Dir::Etc::SourceParts=/dev/null",
            "-o", f"Dir::State::Lists={work / 'lists'}",
            "-o", f"Dir::Cache={work / 'cache'}",
            "-o", "Dir::State::status=/dev/null",
            "-o", "Acquire::IndexTargets::deb::DEP-11::DefaultEnabled=false",
            *(["-o", "APT::Sandbox::User=root"] if os.getuid() == 0 else []),
            "-q"]


def _run(cmd: list[str], cwd: Path | None = None) -> str:
    try:
        r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, check=False,
                           stdin=subprocess.DEVNULL)
    except FileNotFoundError:
        raise UmlError(f"{cmd[0]} is missing (apt-get install {_PROVIDER.get(cmd[0], cmd[0])})")
    if r.returncode != 0:
        tail = (r.stderr or r.stdout).strip().splitlines()[-3:]
        raise UmlError(f"{' '.join(cmd[:2])} failed: {' / '.join(tail)}")
    return r.stdout


_PROVIDER = {"apt-get": "apt", "dpkg-deb": "dpkg", "patchelf": "patchelf"}


def install_cache(dest: Path | None = None, suite: str = CACHE_SUITE) -> Kernel:
    """Fetches Debian ``suite``'s user-mode-linux and libc6 with a private
    apt configuration (``apt-get download``: signatures checked against
    Debian's keyring, nothing installed), unpacks them into ``dest``, keeps
    the CAN modules only, and points the UML binary at the unpacked glibc
    (ELF interpreter and run path, with patchelf). Replaces ``dest`` only
    when all of that worked."""
    dest = (dest or cache_dir()).resolve()
    dest.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=".uml-fetch-", dir=dest.parent))
    try:
        for sub in ("lists/partial", "cache/archives/partial", "debs", "root"):
            (work / sub).mkdir(parents=True)
        (work / "sources.list").write_text(
            f"deb [signed-by={CACHE_KEYRING}] {CACHE_MIRROR} {suite} main\n")
        apt = ["apt-get", *_apt_options(work)]
        _run([*apt, "update"])
        _run([*apt, "download", *CACHE_PACKAGES], cwd=work / "debs")
        versions = {}
        for deb in sorted((work / "debs").glob("*.deb")):
            fields = _run(["dpkg-deb", "-f", str(deb), "Package", "Version"])
            meta = dict(ln.split(": ", 1) for ln in fields.splitlines() if ": " in ln)
            versions[meta["Package"]] = meta["Version"]
            _run(["dpkg-deb", "-x", str(deb), str(work / "root")])
        missing = [p for p in CACHE_PACKAGES if p not in versions]
        if missing:
            raise UmlError(f"Debian {suite} did not give {', '.join(missing)}")
        root = work / "root"
        _prune_modules(root / "usr" / "lib" / "uml" / "modules")
        libdir = dest / "usr" / "lib" / "x86_64-linux-gnu"
        if not (root / "usr" / "lib" / "x86_64-linux-gnu" / "ld-linux-x86-64.so.2").exists():
            raise UmlError(f"Debian {suite}'s libc6 has no x86-64 loader")
        _run(["patchelf", "--set-interpreter", str(libdir / "ld-linux-x86-64.so.2"),
              "--set-rpath", str(libdir), str(root / "usr" / "bin" / SYSTEM_BINARY)])
        (root / "SOURCE.json").write_text(json.dumps(dict(suite=suite, **versions), indent=1))
        old = dest.with_name(dest.name + ".old")
        shutil.rmtree(old, ignore_errors=True)
        if dest.exists():
            dest.rename(old)
        root.rename(dest)
        shutil.rmtree(old, ignore_errors=True)
        return cached_kernel(dest)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _prune_modules(modules: Path) -> None:
    """Keeps only the CAN module folders of every kernel version."""
    for version in modules.iterdir() if modules.is_dir() else ():
        tree = version / "kernel"
        keep = Path(tempfile.mkdtemp(dir=version))
        for sub in CACHE_MODULE_DIRS:
            if (tree / sub).is_dir():
                (keep / sub).parent.mkdir(parents=True, exist_ok=True)
                (tree / sub).rename(keep / sub)
        shutil.rmtree(tree)
        keep.rename(tree)
