# SPDX-License-Identifier: Apache-2.0
"""Sweeps over the geometry: candidates ranked by the duty's margins, on
all local cores or on a Dask cluster.

A candidate is the config with its joints laid out anew from six numbers
(the default platform's pattern: three pairs of joints on a circle at the
base and three on the platform, the platform's pairs turned 60 degrees
from the base's): ``base_radius``, ``platform_radius`` (m), ``base_spacing``,
``platform_spacing`` (degrees between the two joints of a pair),
``home_height`` (z of home, m) and ``bore`` (the piston diameter, m).

The sweep file is JSON: each parameter a fixed number or ``[lo, hi, n]``
(n values from lo to hi); the candidates are every combination.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from .. import config as cfg
from . import analysis, limits
from .duty import DutyError

PARAMS = ["base_radius", "platform_radius", "base_spacing", "platform_spacing", "home_height", "bore"]
_BASE_CENTRES = [270.0, 30.0, 150.0]
_PLATFORM_ANGLES = [(210.0, 1), (330.0, -1), (330.0, 1), (90.0, -1), (90.0, 1), (210.0, -1)]


def joints(params: dict, base_z: float, platform_z: float) -> tuple[list, list]:
    """Base and platform joints of a candidate (leg 1 first)."""
    sb, sp = params["base_spacing"] / 2.0, params["platform_spacing"] / 2.0
    base_deg = [c + s * sb for c in _BASE_CENTRES for s in (-1, 1)]
    plat_deg = [c + s * sp for c, s in _PLATFORM_ANGLES]
    rb, rp = params["base_radius"], params["platform_radius"]
    base = [[rb * math.cos(math.radians(a)), rb * math.sin(math.radians(a)), base_z] for a in base_deg]
    plat = [[rp * math.cos(math.radians(a)), rp * math.sin(math.radians(a)), platform_z] for a in plat_deg]
    return base, plat


def of_platform(platform) -> dict:
    """The six parameters of a platform laid out in the pattern."""
    b = np.asarray(platform.base_joints)
    p = np.asarray(platform.platform_joints)
    return {"base_radius": float(np.hypot(*b[0, :2])), "platform_radius": float(np.hypot(*p[0, :2])),
            "base_spacing": float(np.degrees(np.arctan2(b[1, 1], b[1, 0]) - np.arctan2(b[0, 1], b[0, 0]))),
            "platform_spacing": float(np.degrees(np.arctan2(p[2, 1], p[2, 0]) - np.arctan2(p[1, 1], p[1, 0]))
                                      % 360.0),
            "home_height": float(platform.home[2]), "bore": float(platform.hydraulic["piston_diameter"])}


def candidate(platform, params: dict):
    """The platform with a candidate's geometry; ConfigError when its home
    leaves a stroke or its bore does not fit its rod."""
    base, plat = joints(params, platform.base_joints[0][2], platform.platform_joints[0][2])
    home = list(platform.home)
    home[2] = params["home_height"]
    hyd = dict(platform.hydraulic, piston_diameter=params["bore"])
    if hyd["rod_diameter"] >= params["bore"] or hyd.get("cylinder_outer_diameter", math.inf) <= params["bore"]:
        raise cfg.ConfigError(f"bore {params['bore']:g} m does not fit the rod or the outer diameter")
    p = dataclasses.replace(platform, base_joints=base, platform_joints=plat, home=home, hydraulic=hyd)
    for i, length in enumerate(cfg.leg_lengths(p, home)):
        if not p.leg_length_min <= length <= p.leg_length_max:
            raise cfg.ConfigError(f"home leaves leg {i + 1}'s stroke ({length:.3f} m)")
    return p


def read_spec(path, platform) -> list[dict]:
    """Every combination of the sweep file's parameters (absent ones keep
    the platform's value); DutyError naming a bad key."""
    try:
        spec = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise DutyError(f"{path}: cannot read the sweep: {e}") from None
    if not isinstance(spec, dict):
        raise DutyError(f"{path}: expected an object")
    base = of_platform(platform)
    values = []
    for k in spec:
        if k not in PARAMS:
            raise DutyError(f"{path}: {k}: unknown key (known: {', '.join(PARAMS)})")
    for k in PARAMS:
        v = spec.get(k, base[k])
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            values.append([float(v)])
        elif (isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) for x in v)
              and v[0] <= v[1] and isinstance(v[2], int) and 1 <= v[2] <= 1000):
            values.append(np.linspace(v[0], v[1], v[2]).tolist())
        else:
            raise DutyError(f"{path}: {k}: expected a number or [lo, hi, n] with lo <= hi, n an integer 1..1000")
    return [dict(zip(PARAMS, combo)) for combo in itertools.product(*values)]


def _normalised(platform, item: dict) -> float:
    """A verdict item's margin as a fraction: relative margins as they are,
    the workspace's over the stroke, the pressure's over the supply."""
    if item["unit"] == "relative":
        return item["margin"]
    if item["unit"] == "bar":
        return item["margin"] * 1e5 / platform.hydraulic["supply_pressure"]
    return item["margin"] / (platform.leg_length_max - platform.leg_length_min)


def evaluate(platform, duty, params: dict, points: int) -> dict:
    """One candidate's summary: its score (the least normalised margin),
    how many requirements it fails and what limits it most."""
    row = dict(params)
    try:
        p = candidate(platform, params)
        r = analysis.run(p, duty, full=False, points=points)
    except (cfg.ConfigError, np.linalg.LinAlgError) as e:
        row.update(score=-math.inf, failed=-1, limit=str(e))
        return row
    scored = [(_normalised(p, v), v) for v in r["verdict"]]
    score, worst = min(scored, key=lambda s: s[0])
    row.update(score=float(score), failed=sum(1 for v in r["verdict"] if not v["pass"]),
               limit=f"{worst['requirement']}: {worst['limit']}", lowest_hz=r["stiffness"]["lowest_hz"],
               push=r["forces"]["push"]["value"], pull=r["forces"]["pull"]["value"])
    return row


def evaluate_chunk(platform, duty, chunk: list, points: int) -> list:
    return [evaluate(platform, duty, params, points) for params in chunk]


def _chunks(cands: list, n: int) -> list:
    size = max(1, math.ceil(len(cands) / n))
    return [cands[i:i + size] for i in range(0, len(cands), size)]


def run_local(platform, duty, cands: list, points: int, workers: int | None = None) -> list:
    """All candidates on ``workers`` local processes (default: every core)."""
    workers = workers or os.cpu_count() or 1
    if workers == 1:
        return evaluate_chunk(platform, duty, cands, points)
    chunks = _chunks(cands, workers * 8)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        parts = pool.map(evaluate_chunk, [platform] * len(chunks), [duty] * len(chunks), chunks,
                         [points] * len(chunks))
        return [row for part in parts for row in part]


def run_dask(platform, duty, cands: list, points: int, scheduler) -> list:
    """All candidates on a Dask cluster: ``scheduler`` is its address or a
    ``distributed.Client``. Dask is imported only here."""
    try:
        from distributed import Client
    except ImportError as e:  # the package works without it
        raise RuntimeError("a Dask sweep needs the distributed package (pip install 'dask[distributed]')") from e
    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        workers = max(1, sum(client.nthreads().values()))
        plat, dut = client.scatter([platform, duty], broadcast=True)
        chunks = _chunks(cands, workers * 8)
        n = len(chunks)
        futures = client.map(evaluate_chunk, [plat] * n, [dut] * n, chunks, [points] * n, pure=False)
        return [row for part in client.gather(futures) for row in part]
    finally:
        if client is not scheduler:
            client.close()


def rank(rows: list) -> list:
    """Best first: candidates meeting every requirement, then by score."""
    return sorted(rows, key=lambda r: (r["failed"] != 0, -r["score"]))
