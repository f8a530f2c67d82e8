"""The operator's side of command authentication (firmware sp/auth.h,
docs/security.md): the code of a frame is SipHash-2-4 under the machine's
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
