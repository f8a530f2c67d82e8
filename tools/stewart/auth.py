# SPDX-License-Identifier: Apache-2.0
"""The operator's side of command authentication (firmware sp/link/auth.h,
docs/explanation/security.md): the code of a frame is SipHash-2-4 under the machine's
128-bit key of

    data ID (2 bytes LE) | session (4 bytes LE) | counter (4 bytes LE) | payload

truncated to the frame's tag field (its low bytes, little-endian). The
SipHash itself comes from the ``siphash24`` package (PyPI), an
implementation the firmware's is checked against (tests/python/test_auth.py).
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

from siphash24 import siphash24

KEY_BYTES = 16
HEADER_BYTES = 10
PAYLOAD_MAX = 64
TAG_MIN_BYTES = 4
TAG_MAX_BYTES = 8
#: The environment variable naming the machine key file when no --key is
#: given (``stewart op``, ``sp_controller``, ``hs_sim``).
KEY_ENV = "STEWART_KEY"
#: How far past CTRL_AUTH's LastCounter an operator process starts: the value
#: may be up to 10 ms (one CTRL_AUTH period) old, and another process may
#: have sent a frame a millisecond since.
COUNTER_MARGIN = 64


class AuthError(ValueError):
    """A key that cannot be used, or a frame that cannot be signed."""


def siphash(key: bytes, msg: bytes) -> int:
    """SipHash-2-4 of ``msg`` under ``key`` as the 64-bit value (the
    reference's output bytes read little-endian)."""
    if len(key) != KEY_BYTES:
        raise AuthError(f"a key is {KEY_BYTES} bytes, got {len(key)}")
    return int.from_bytes(siphash24(bytes(msg), key=bytes(key)).digest(), "little")


def tag(key: bytes, frame_id: int, session: int, counter: int, payload: bytes) -> int:
    """The 64-bit code of one frame (sp_auth_tag)."""
    if not 0 <= frame_id <= 0x7FF:
        raise AuthError(f"frame ID 0x{frame_id:X} is not an 11-bit identifier")
    if len(payload) > PAYLOAD_MAX:
        raise AuthError(f"at most {PAYLOAD_MAX} payload bytes are covered, got {len(payload)}")
    head = struct.pack("<HII", frame_id, session & 0xFFFFFFFF, counter & 0xFFFFFFFF)
    return siphash(key, head + bytes(payload))


def tag_bytes(key: bytes, frame_id: int, session: int, counter: int, payload: bytes, n: int) -> bytes:
    """The frame's tag field: the code's low ``n`` bytes (4..8), little-endian."""
    if not TAG_MIN_BYTES <= n <= TAG_MAX_BYTES:
        raise AuthError(f"a tag is {TAG_MIN_BYTES} to {TAG_MAX_BYTES} bytes, got {n}")
    return tag(key, frame_id, session, counter, payload).to_bytes(8, "little")[:n]


def read_key(path: str | Path) -> bytes:
    """A key file: 32 hexadecimal digits (whitespace and a trailing newline
    allowed). Refuses a file others may read, as ssh does a private key."""
    p = Path(path)
    try:
        text = p.read_text()
        mode = p.stat().st_mode
    except OSError as exc:
        raise AuthError(f"cannot read the key file {p}: {exc.strerror}") from exc
    if mode & 0o077:
        raise AuthError(f"{p}: the key file may be read by others (mode {mode & 0o777:o}); chmod 600 it")
    digits = "".join(text.split())
    try:
        key = bytes.fromhex(digits)
    except ValueError:
        raise AuthError(f"{p}: a key file holds {2 * KEY_BYTES} hexadecimal digits") from None
    if len(key) != KEY_BYTES:
        raise AuthError(f"{p}: a key file holds {2 * KEY_BYTES} hexadecimal digits, got {len(digits)}")
    return key


def new_key_file(path: str | Path) -> Path:
    """Writes a fresh random key (os.urandom) to ``path``, readable by its
    owner only; refuses to overwrite one."""
    p = Path(path)
    fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(os.urandom(KEY_BYTES).hex() + "\n")
    return p


def key_file(path: str | Path | None = None) -> Path | None:
    """The key file to use: ``path``, else the one STEWART_KEY names, else None."""
    if path:
        return Path(path)
    env = os.environ.get(KEY_ENV, "")
    return Path(env) if env else None


def machine_key(path: str | Path | None = None) -> bytes | None:
    """The key of :func:`key_file` read (None: no key given); AuthError for
    a file that cannot be read or is not a key."""
    k = key_file(path)
    return None if k is None else read_key(k)


def run_key(directory: str | Path) -> Path:
    """The key of a closed-loop run, the demo or a test: the file STEWART_KEY
    names, else a throw-away key ``machine.key`` in ``directory`` (made once,
    mode 600, so that the runs of one directory share it: their logs are
    comparable byte for byte)."""
    k = key_file()
    if k is not None:
        return k
    p = Path(directory) / "machine.key"
    if not p.exists():
        Path(directory).mkdir(parents=True, exist_ok=True)
        new_key_file(p)
    return p


class Signer:
    """Signs the operator's authenticated frames (OP_COMMAND but NONE, STOP,
    PARK, ESTOP, IDENTIFY; OP_TARGET_POSE; OP_FORCE; OP_FORCE_PARAMS) with the machine key, the
    controller's session and the next counter; the layout (AuthCounter,
    AuthTag) comes from the DBC. ``session`` None: not known yet."""

    EXEMPT_COMMANDS = ("NONE", "STOP", "PARK", "ESTOP", "IDENTIFY")

    def __init__(self, db, key: bytes):
        from . import e2e

        self._e2e = e2e
        self.key = bytes(key)
        if len(self.key) != KEY_BYTES:
            raise AuthError(f"a key is {KEY_BYTES} bytes, got {len(self.key)}")
        self.session: int | None = None
        self.counter = 0  # the last counter used
        self.layout: dict[int, tuple[int, int, int]] = {}
        self.exempt: set[int] = set()
        for m in db.messages:
            names = {s.name: s for s in m.signals}
            if "AuthTag" in names and "AuthCounter" in names:
                c, tg = names["AuthCounter"], names["AuthTag"]
                self.layout[m.frame_id] = (c.start // 8, tg.start // 8, tg.length // 8)
                if m.name == "OP_COMMAND":
                    self._command_id = m.frame_id
                    choices = m.get_signal_by_name("Command").choices or {}
                    self.exempt = {int(v) for v, n in choices.items() if str(n) in self.EXEMPT_COMMANDS}

    def needs(self, frame_id: int, data: bytes) -> bool:
        """Whether this frame must carry a code."""
        if frame_id not in self.layout:
            return False
        return not (frame_id == getattr(self, "_command_id", -1) and data[0] in self.exempt)

    def follow(self, session: int, last_counter: int) -> None:
        """CTRL_AUTH's values: a new session restarts the counter after its
        LastCounter (plus COUNTER_MARGIN); within the session the counter
        jumps past LastCounter when another operator went past it."""
        if self.session != session:
            self.session = session
            self.counter = min(last_counter + COUNTER_MARGIN, 0xFFFFFFFF)
        elif last_counter > self.counter:
            self.counter = min(last_counter + COUNTER_MARGIN, 0xFFFFFFFF)

    def sign(self, frame_id: int, data: bytes) -> bytes:
        """The frame with its AuthCounter, AuthTag and CRC filled in (frames
        that need no code are returned as they are)."""
        if not self.needs(frame_id, data):
            return bytes(data)
        if self.session is None:
            raise AuthError("no session from the controller yet (no CTRL_AUTH heard)")
        if self.counter >= 0xFFFFFFFF:
            raise AuthError("this session's counters are used up: restart the controller")
        self.counter += 1
        cbyte, tbyte, tlen = self.layout[frame_id]
        b = bytearray(data)
        b[cbyte:cbyte + 2] = (self.counter & 0xFFFF).to_bytes(2, "little")
        b[tbyte:tbyte + tlen] = tag_bytes(self.key, frame_id, self.session, self.counter, bytes(b[:tbyte]), tlen)
        return self._e2e.seal(frame_id, bytes(b))
