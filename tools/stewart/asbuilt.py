# SPDX-License-Identifier: Apache-2.0
"""The machine as built: the ``as_built`` section of a platform config.

The plant simulator (tools/dev/gen_plant.py -> host_sim) reads it; the
controller (tools/dev/gen_platform.py, :mod:`stewart.config`) never does.
It holds what the real machine has and its drawing does not:

- ``base_joints``, ``platform_joints``: six [dx, dy, dz] each, m, added to
  the config's joint coordinates (base frame / motion frame);
- ``length_zero``: six numbers, m: what each leg's length sensor reads
  beyond the joint-to-joint length at ``leg_length_min``;
- ``length_scale``: six numbers (dimensionless, e.g. 1e-4 = 100 ppm): the
  sensor's gain error over the stroke;
- ``seed``, ``joint_sigma``, ``zero_sigma``, ``scale_sigma``: how it was drawn
  (informative, optional).

A sensor reads ``r = lmin + (1 + scale) (l - lmin) + zero`` at the
joint-to-joint length ``l`` (:func:`reading`). Standard library only: the
plant's generator runs before any virtual environment exists.
"""

from __future__ import annotations

import json
import math
import random

LEGS = 6
KEYS = ("base_joints", "platform_joints", "length_zero", "length_scale")
INFO_KEYS = ("seed", "joint_sigma", "zero_sigma", "scale_sigma")
JOINT_MAX = 0.05   # m: a joint 5 cm off its drawing is a different machine
ZERO_MAX = 0.05    # m
SCALE_MAX = 0.01   # 1 %


class AsBuiltError(ValueError):
    """An ``as_built`` section that cannot be used; the message names the key."""


def _num(where, v, lim):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise AsBuiltError(f"{where}: expected a finite number, got {json.dumps(v)[:40]}")
    if abs(float(v)) > lim:
        raise AsBuiltError(f"{where}: {float(v):g} is beyond +-{lim:g}")
    return float(v)


def _vec(where, v, n, lim):
    if not isinstance(v, list) or len(v) != n:
        raise AsBuiltError(f"{where}: expected a list of {n} numbers")
    return [_num(f"{where}[{i}]", x, lim) for i, x in enumerate(v)]


def parse(d) -> dict:
    """The validated ``as_built`` section of a raw config dict (absent: all
    zero, the machine as drawn). Raises AsBuiltError naming the key."""
    s = d.get("as_built", {}) if isinstance(d, dict) else {}
    if not isinstance(s, dict):
        raise AsBuiltError("as_built: expected an object")
    for key in s:
        if key not in KEYS and key not in INFO_KEYS:
            raise AsBuiltError(f"as_built.{key}: unknown key (known: {', '.join(KEYS + INFO_KEYS)})")
    out = {}
    for key in ("base_joints", "platform_joints"):
        rows = s.get(key, [[0.0] * 3] * LEGS)
        if not isinstance(rows, list) or len(rows) != LEGS:
            raise AsBuiltError(f"as_built.{key}: expected {LEGS} rows of 3 numbers")
        out[key] = [_vec(f"as_built.{key}[{i}]", r, 3, JOINT_MAX) for i, r in enumerate(rows)]
    out["length_zero"] = _vec("as_built.length_zero", s.get("length_zero", [0.0] * LEGS), LEGS, ZERO_MAX)
    out["length_scale"] = _vec("as_built.length_scale", s.get("length_scale", [0.0] * LEGS), LEGS, SCALE_MAX)
    return out


def true_config(d: dict) -> dict:
    """A copy of the raw config ``d`` with the as-built joint coordinates in
    place of the drawn ones and without the ``as_built`` section."""
    ab = parse(d)
    out = {k: v for k, v in d.items() if k != "as_built"}
    for key in ("base_joints", "platform_joints"):
        out[key] = [[float(x) + dx for x, dx in zip(row, off)] for row, off in zip(d[key], ab[key])]
    return out


def plant_file(section: dict) -> str:
    """The text ``hs_sim --as-built FILE`` reads: the 48 numbers of a parsed
    section (base_joints, platform_joints, length_zero, length_scale), the
    machine as built without rebuilding the plant."""
    rows = ["# as built: base_joints 6x3 m, platform_joints 6x3 m, length_zero 6 m, length_scale 6 (hs_sim --as-built)"]
    for key in ("base_joints", "platform_joints"):
        rows += [" ".join(repr(float(x)) for x in r) for r in section[key]]
    rows += [" ".join(repr(float(x)) for x in section[key]) for key in ("length_zero", "length_scale")]
    return "\n".join(rows) + "\n"


def reading(length: float, zero: float, scale: float, lmin: float) -> float:
    """What a length sensor reads at the joint-to-joint length (m)."""
    return lmin + (1.0 + scale) * (length - lmin) + zero


def draw(seed: int, joint_sigma: float, zero_sigma: float, scale_sigma: float = 0.0) -> dict:
    """An ``as_built`` section drawn from normal spreads (m, m, dimensionless),
    each clipped to 4 sigma."""
    rng = random.Random(seed)

    def g(sigma):
        return max(-4.0 * sigma, min(4.0 * sigma, rng.gauss(0.0, sigma))) if sigma > 0 else 0.0
    return {
        "seed": seed, "joint_sigma": joint_sigma, "zero_sigma": zero_sigma, "scale_sigma": scale_sigma,
        "base_joints": [[g(joint_sigma) for _ in range(3)] for _ in range(LEGS)],
        "platform_joints": [[g(joint_sigma) for _ in range(3)] for _ in range(LEGS)],
        "length_zero": [g(zero_sigma) for _ in range(LEGS)],
        "length_scale": [g(scale_sigma) for _ in range(LEGS)],
    }
