"""Command authentication: the firmware's SipHash-2-4 and frame codes
(sp/auth.h, through the core library) against the ``siphash24`` package, an
implementation we did not write, on many random keys and messages of every
length the firmware takes; and the key file's checks."""

from __future__ import annotations

import ctypes as C
import os
import random

import pytest

from stewart import auth
from stewart import core


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
