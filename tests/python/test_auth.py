# SPDX-License-Identifier: Apache-2.0
"""Command authentication: the firmware's SipHash-2-4 and frame codes
(sp/link/auth.h, through the core library) against the ``siphash24`` package, an
implementation we did not write, on many random keys and messages of every
length the firmware takes; and the key file's checks."""

from __future__ import annotations

import ctypes as C
import os
import random
from pathlib import Path

import pytest

from stewart import auth
from stewart import core

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def L():
    lib = core.lib()
    lib.sp_siphash24.argtypes = [C.c_char_p, C.c_char_p, C.c_uint32, C.POINTER(C.c_uint64)]
    lib.sp_siphash24.restype = C.c_int
    lib.sp_auth_tag.argtypes = [C.c_char_p, C.c_uint32, C.c_uint32, C.c_uint32, C.c_char_p, C.c_uint32,
                                C.POINTER(C.c_uint64)]
    lib.sp_auth_tag.restype = C.c_int
    return lib


def test_published_values():
    key = bytes(range(16))
    assert auth.siphash(key, bytes(range(15))) == 0xA129CA6149BE45E5
    assert auth.siphash(key, b"") == 0x726FDB47DD0E0E31


def test_firmware_siphash_equals_the_package(L):
    rng = random.Random(408)
    out = C.c_uint64()
    for n in range(3000):
        key = rng.randbytes(16)
        msg = rng.randbytes(n % (auth.HEADER_BYTES + auth.PAYLOAD_MAX + 1))
        assert L.sp_siphash24(key, msg, len(msg), C.byref(out)) == 0
        assert out.value == auth.siphash(key, msg), (key.hex(), msg.hex())
    # positive control: the comparison sees a one-bit difference
    assert L.sp_siphash24(key, msg[:-1] + bytes([msg[-1] ^ 1]), len(msg), C.byref(out)) == 0
    assert out.value != auth.siphash(key, msg)
    # too long for the firmware: refused, not truncated
    long = bytes(auth.HEADER_BYTES + auth.PAYLOAD_MAX + 1)
    assert L.sp_siphash24(key, long, len(long), C.byref(out)) != 0


def test_firmware_frame_code_equals_the_tools(L):
    rng = random.Random(402)
    out = C.c_uint64()
    for _ in range(1000):
        key = rng.randbytes(16)
        fid, session, counter = rng.randrange(0x800), rng.getrandbits(32), rng.getrandbits(32)
        payload = rng.randbytes(rng.randrange(auth.PAYLOAD_MAX + 1))
        assert L.sp_auth_tag(key, fid, session, counter, payload, len(payload), C.byref(out)) == 0
        assert out.value == auth.tag(key, fid, session, counter, payload)
        n = rng.randrange(4, 9)
        assert auth.tag_bytes(key, fid, session, counter, payload, n) == out.value.to_bytes(8, "little")[:n]


def test_bad_arguments():
    key = bytes(16)
    with pytest.raises(auth.AuthError, match="16 bytes"):
        auth.siphash(bytes(15), b"")
    with pytest.raises(auth.AuthError, match="11-bit"):
        auth.tag(key, 0x800, 0, 1, b"")
    with pytest.raises(auth.AuthError, match="at most 64"):
        auth.tag(key, 0x40, 0, 1, bytes(65))
    with pytest.raises(auth.AuthError, match="4 to 8"):
        auth.tag_bytes(key, 0x40, 0, 1, b"", 3)


def test_key_files(tmp_path):
    p = auth.new_key_file(tmp_path / "machine.key")
    assert oct(p.stat().st_mode & 0o777) == "0o600"
    assert len(auth.read_key(p)) == 16
    with pytest.raises(FileExistsError):
        auth.new_key_file(p)
    os.chmod(p, 0o644)
    with pytest.raises(auth.AuthError, match="read by others"):
        auth.read_key(p)
    bad = tmp_path / "bad.key"
    bad.write_text("xyz\n")
    os.chmod(bad, 0o600)
    with pytest.raises(auth.AuthError, match="32 hexadecimal digits"):
        auth.read_key(bad)
    short = tmp_path / "short.key"
    short.write_text("00ff\n")
    os.chmod(short, 0o600)
    with pytest.raises(auth.AuthError, match="got 4"):
        auth.read_key(short)
    with pytest.raises(auth.AuthError, match="cannot read"):
        auth.read_key(tmp_path / "missing.key")


def test_build_key_header(tmp_path):
    """tools/dev/key_header.py (the STM32 build's key): makes a missing
    key file (mode 600) and says so, keeps an existing one, writes the
    header with its bytes, and refuses a readable or malformed file."""
    import subprocess
    import sys

    script = REPO_ROOT / "tools" / "dev" / "key_header.py"
    key, hdr = tmp_path / "k" / "machine.key", tmp_path / "h" / "sp_machine_key.h"
    r = subprocess.run([sys.executable, str(script), str(key), str(hdr)], capture_output=True, text=True)
    assert r.returncode == 0 and "made a new random one" in r.stderr and "never commit" in r.stderr
    assert oct(key.stat().st_mode & 0o777) == "0o600"
    k = auth.read_key(key)
    text = hdr.read_text()
    assert "#define SP_MACHINE_KEY_BYTES {" + ", ".join(f"0x{b:02x}u" for b in k) + "}" in text
    before = hdr.stat().st_mtime_ns
    r = subprocess.run([sys.executable, str(script), str(key), str(hdr)], capture_output=True, text=True)
    assert r.returncode == 0 and r.stderr == "" and auth.read_key(key) == k
    assert hdr.stat().st_mtime_ns == before  # unchanged: nothing to rebuild
    os.chmod(key, 0o644)
    r = subprocess.run([sys.executable, str(script), str(key), str(hdr)], capture_output=True, text=True)
    assert r.returncode == 1 and "read by others" in r.stderr
    bad = tmp_path / "bad.key"
    bad.write_text("00ff\n")
    os.chmod(bad, 0o600)
    r = subprocess.run([sys.executable, str(script), str(bad), str(hdr)], capture_output=True, text=True)
    assert r.returncode == 1 and "32 hexadecimal digits" in r.stderr


def test_signer_follows_the_controller():
    """auth.Signer (stewart op): a new session starts past CTRL_AUTH's
    LastCounter by the margin; it jumps past another operator's counter;
    a stale CTRL_AUTH (a lower LastCounter) changes nothing; NONE and the
    stops are left unsigned; no session, no signature."""
    from stewart import e2e
    from stewart import protocol as pr

    proto = pr.Protocol()
    s = auth.Signer(proto.db, bytes(range(16)))
    cmd = proto.encode("OP_COMMAND", pr.command_signals("ENGAGE"), 0)
    with pytest.raises(auth.AuthError, match="no session"):
        s.sign(0x040, cmd)
    s.follow(0xABCD, 100)
    assert s.counter == 100 + auth.COUNTER_MARGIN
    signed = s.sign(0x040, cmd)
    assert s.counter == 101 + auth.COUNTER_MARGIN and e2e.crc_ok(0x040, signed)
    assert int.from_bytes(signed[10:12], "little") == s.counter & 0xFFFF
    assert signed[12:18] == auth.tag_bytes(bytes(range(16)), 0x040, 0xABCD, s.counter, signed[:12], 6)
    s.follow(0xABCD, 50)  # stale
    assert s.counter == 101 + auth.COUNTER_MARGIN
    s.follow(0xABCD, 1000)  # another operator went past
    assert s.counter == 1000 + auth.COUNTER_MARGIN
    s.follow(0x1234, 0)  # a restarted controller
    assert (s.session, s.counter) == (0x1234, auth.COUNTER_MARGIN)
    for c in ("NONE", "STOP", "PARK", "ESTOP"):
        f = proto.encode("OP_COMMAND", pr.command_signals(c), 0)
        assert not s.needs(0x040, f) and s.sign(0x040, f) == f
    assert s.needs(0x050, bytes(32)) and s.needs(0x048, bytes(32)) and not s.needs(0x060, bytes(4))
