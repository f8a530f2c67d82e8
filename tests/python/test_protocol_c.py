# SPDX-License-Identifier: Apache-2.0
"""C and Python byte compatibility on the shared test vectors
(protocol/test_vectors.json, produced by the Python side): the firmware's C
protocol layer (through the core shared library) decodes every vector, and
re-encoding what it decoded with the same counter gives back exactly the
same bytes, CRC included; every malformed frame is rejected by the C node
with the same reason that Python gives."""

import ctypes as C
import json
from pathlib import Path

import pytest

from stewart.core import CanFrame, lib

REPO_ROOT = Path(__file__).resolve().parents[2]

VECTORS = json.loads((REPO_ROOT / "protocol" / "test_vectors.json").read_text())
BUS = {"ops": 0, "axis_a": 1, "axis_b": 2}


def frame(frame_id, data: bytes, bus=0):
    f = CanFrame()
    f.id = frame_id
    f.bus = bus
    f.len = len(data)
    f.flags = 3
    for i, b in enumerate(data):
        f.data[i] = b
    return f


# message -> (decode, encode, call shape); buffers are opaque to Python
CODECS = {
    "SYNC": ("sp_proto_decode_sync", "sp_proto_encode_sync", "bus"),
    "AXIS_SETPOINTS": ("sp_proto_decode_setpoints", "sp_proto_encode_setpoints", "bus"),
    "AXIS_FEEDBACK_1": ("sp_proto_decode_feedback", "sp_proto_encode_feedback", "slot"),
    "AXIS_FEEDBACK_2": ("sp_proto_decode_feedback", "sp_proto_encode_feedback", "slot"),
    "AXIS_FEEDBACK_3": ("sp_proto_decode_feedback", "sp_proto_encode_feedback", "slot"),
    "OP_COMMAND": ("sp_proto_decode_command", "sp_proto_encode_command", "ops"),
    "OP_TARGET_POSE": ("sp_proto_decode_target", "sp_proto_encode_target", "ops"),
    "OP_HEARTBEAT": ("sp_proto_decode_heartbeat", "sp_proto_encode_heartbeat", "bare"),
    "OP_FORCE": ("sp_proto_decode_force", "sp_proto_encode_force", "ops"),
    "OP_FORCE_PARAMS": ("sp_proto_decode_force_params", "sp_proto_encode_force_params", "ops"),
    "FT_SENSOR": ("sp_proto_decode_ft", "sp_proto_encode_ft", "ops"),
    "CTRL_STATUS": ("sp_proto_decode_status", "sp_proto_encode_status", "ops"),
    "CTRL_MONITOR": ("sp_proto_decode_monitor", "sp_proto_encode_monitor", "ops"),
    "CTRL_WRENCH": ("sp_proto_decode_wrench", "sp_proto_encode_wrench", "ops"),
    "CTRL_AUTH": ("sp_proto_decode_auth", "sp_proto_encode_auth", "ops"),
    "CTRL_IDENTITY": ("sp_proto_decode_identity", "sp_proto_encode_identity", "ops"),
    "OP_FRAME": ("sp_proto_decode_frame", "sp_proto_encode_frame", "ops"),
    "OP_REACH": ("sp_proto_decode_reach", "sp_proto_encode_reach", "ops"),
    "CTRL_REACH": ("sp_proto_decode_reach_answer", "sp_proto_encode_reach_answer", "ops"),
    "CTRL_FRAMES": ("sp_proto_decode_frames", "sp_proto_encode_frames", "ops"),
    "CTRL_REFUSAL": ("sp_proto_decode_refusal", "sp_proto_encode_refusal", "ops"),
}


def _signer():
    from stewart import auth
    from stewart.protocol import Protocol

    return auth.Signer(Protocol().db, bytes(range(16)))


def c_roundtrip(L, vec):
    dec, enc, shape = CODECS[vec["message"]]
    data = bytes.fromhex(vec["data"])
    f = frame(vec["frame_id"], data)
    msg = C.create_string_buffer(512)
    counter = C.c_uint8()
    err = C.c_int()
    slot = C.c_uint8()
    if shape == "slot":
        st = getattr(L, dec)(C.byref(f), msg, C.byref(slot), C.byref(counter), C.byref(err))
    elif shape == "bare":
        st = getattr(L, dec)(C.byref(f), C.byref(counter), C.byref(err))
    else:
        st = getattr(L, dec)(C.byref(f), msg, C.byref(counter), C.byref(err))
    if st != 0:
        return st, err.value, None
    out = CanFrame()
    if shape == "bus":
        st = getattr(L, enc)(msg, counter, C.c_uint8(1), C.byref(out))
    elif shape == "slot":
        st = getattr(L, enc)(msg, slot, counter, C.c_uint8(1), C.byref(out))
    elif shape == "bare":
        st = getattr(L, enc)(counter, C.byref(out))
    else:
        st = getattr(L, enc)(msg, counter, C.byref(out))
    return st, 0, bytes(out.data[: out.len])


@pytest.mark.parametrize("vec", VECTORS["vectors"], ids=lambda v: f"{v['message']}-{v['case']}")
def test_c_decodes_and_reencodes_every_vector_byte_for_byte(vec):
    L = lib()
    st, err, again = c_roundtrip(L, vec)
    assert st == 0, f"C rejected a valid vector (status {st}, reason {err})"
    data = bytes.fromhex(vec["data"])
    lay = _signer().layout.get(vec["frame_id"])
    if lay is not None:
        # the encoders leave the authentication fields to sp_proto_sign
        # (test_c_signs_like_python): the vector's are put back
        from stewart import e2e

        cb, tb, tl = lay
        assert again[cb:cb + 2] == bytes(2) and again[tb:tb + tl] == bytes(tl)
        b = bytearray(again)
        b[cb:cb + 2], b[tb:tb + tl] = data[cb:cb + 2], data[tb:tb + tl]
        again = e2e.seal(vec["frame_id"], bytes(b))
    assert again == data


def test_c_signs_like_python():
    """sp_proto_sign (firmware) and auth.Signer (stewart op) give the same
    bytes on every authenticated vector, for sessions and counters across
    their ranges and the 16-bit laps; a one-bit change of key differs."""
    import random

    from stewart import auth

    L = lib()
    rng = random.Random(17)
    n = 0
    signed = set()
    for vec in VECTORS["vectors"]:
        s = _signer()
        if vec["frame_id"] not in s.layout:
            continue
        if vec["message"] == "OP_COMMAND" and not s.needs(vec["frame_id"], bytes.fromhex(vec["data"])):
            continue
        for _ in range(40):
            key = bytes(rng.randrange(256) for _ in range(16))
            session = rng.choice([0, 1, 0xFFFFFFFF, rng.randrange(1 << 32)])
            counter = rng.choice([1, 0xFFFF, 0x10000, 0x10001, 0xFFFFFFFF, rng.randrange(1, 1 << 32)])
            s = auth.Signer(_db(), key)
            s.session, s.counter = session, counter - 1
            want = s.sign(vec["frame_id"], bytes.fromhex(vec["data"]))
            f = frame(vec["frame_id"], bytes.fromhex(vec["data"]))
            k = (C.c_uint8 * 16)(*key)
            assert L.sp_proto_sign(C.byref(f), k, C.c_uint32(session), C.c_uint32(counter)) == 0
            assert bytes(f.data[: f.len]) == want
            other = bytearray(key)
            other[rng.randrange(16)] ^= 1 << rng.randrange(8)
            f2 = frame(vec["frame_id"], bytes.fromhex(vec["data"]))
            k2 = (C.c_uint8 * 16)(*other)
            assert L.sp_proto_sign(C.byref(f2), k2, C.c_uint32(session), C.c_uint32(counter)) == 0
            assert bytes(f2.data[: f2.len]) != want
            n += 1
            signed.add(vec["message"])
    assert signed == {"OP_COMMAND", "OP_TARGET_POSE", "OP_FORCE", "OP_FORCE_PARAMS", "OP_FRAME"}
    assert n >= 4 * 3 * 40
    # counter 0 is never valid; a message without the fields is refused
    f = frame(0x060, bytes(4))
    assert L.sp_proto_sign(C.byref(f), (C.c_uint8 * 16)(), C.c_uint32(1), C.c_uint32(1)) != 0
    f = frame(0x050, bytes(32))
    assert L.sp_proto_sign(C.byref(f), (C.c_uint8 * 16)(), C.c_uint32(1), C.c_uint32(0)) != 0
    assert L.sp_proto_sign(C.byref(f), (C.c_uint8 * 16)(), C.c_uint32(1), C.c_uint32(1)) == 0
    f.len = 24
    assert L.sp_proto_sign(C.byref(f), (C.c_uint8 * 16)(), C.c_uint32(1), C.c_uint32(1)) != 0


def _db():
    from stewart.protocol import Protocol

    return Protocol().db


def test_c_node_rejects_malformed_frames_like_python():
    L = lib()
    L.sp_proto_error_name.restype = C.c_char_p
    platform = C.addressof(C.c_char.in_dll(L, "sp_platform_default"))
    checked = 0
    for m in VECTORS["malformed"]:
        if m["kind"] in ("repeated", "wrong-sequence"):
            continue  # counter sequences are covered by the C unit tests
        cfg = C.create_string_buffer(4096)
        node = C.create_string_buffer(1 << 16)
        assert L.sp_node_default_config(cfg, C.c_void_p(platform)) == 0
        assert L.sp_node_init(node, cfg) == 0
        name = next((k for k, v in VECTORS["messages"].items() if v["frame_id"] == m["frame_id"]), None)
        bus = BUS[VECTORS["messages"][name]["buses"][0]] if name else 0
        why = C.c_int()
        f = frame(m["frame_id"], bytes.fromhex(m["data"]), bus)
        st = L.sp_node_receive(node, C.byref(f), C.byref(why))
        # frames the controller does not consume (its own messages) are
        # unknown to it whatever else is wrong with them
        ours = name in ("SYNC", "AXIS_FEEDBACK_1", "AXIS_FEEDBACK_2", "AXIS_FEEDBACK_3", "OP_COMMAND",
                        "OP_TARGET_POSE", "OP_HEARTBEAT", "OP_FORCE", "FT_SENSOR")
        expect = m["kind"] if ours or name is None else "unknown-id"
        if name == "SYNC":
            expect = "unknown-id"  # a real-time controller is the SYNC master itself
        assert st == 8, m
        assert L.sp_proto_error_name(why.value).decode() == expect, m
        checked += 1
    assert checked >= 8
