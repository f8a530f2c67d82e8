# SPDX-License-Identifier: Apache-2.0
"""Motion cueing: a classical washout filter from vehicle telemetry to
platform poses (docs/explanation/cueing.md explains the why of each part).

Input per sample (vehicle frame: x forward, y left, z up):

* specific force ``f`` = acceleration minus gravity, m/s^2, what an
  accelerometer in the vehicle reads (at rest on level ground
  ``(0, 0, +9.80665)``);
* angular rate ``w`` (roll, pitch, yaw rate), rad/s.

Output: the platform pose ``[x, y, z, roll, pitch, yaw]`` (m, rad; base frame,
Z-Y-X Euler angles as everywhere in the project), absolute: the config's
``home`` plus the cue. Three paths, all linear filters discretised exactly
(zero-order hold) except the tilt's rate limiter:

1. **Translation**: the scaled specific force less gravity, high-passed
   (third order: a second-order high pass times a first-order one) and
   integrated twice, per axis. Written as one filter from acceleration to
   position, ``s / ((s^2 + 2 zeta w s + w^2)(s + w_b))``: a sustained
   acceleration gives a transient displacement that returns to home.
2. **Tilt coordination**: the scaled longitudinal and lateral specific force,
   low-passed (second order), becomes a pitch and roll that let gravity
   supply it (``pitch = -asin(f_x / g)``, ``roll = asin(f_y / g)``), with the
   tilt's rate limited below what the vestibular system notices as rotation
   and its angle limited.
3. **Rotation**: the scaled angular rate, high-passed (second order) and
   integrated, ``s / (s^2 + 2 zeta w s + w^2)`` per axis, added to the tilt.
   Small-angle: the rates are integrated as Euler angle rates.

Last resort: each pose is clipped to ``params.margin`` of the platform's
workspace box (config ``workspace``, relative to ``home``), and the clipped
samples are counted per axis (:attr:`Washout.clipped`). The default
parameters keep the aggressive synthetic drive of the tests inside the
workspace and the legs inside their stroke without clipping.

>>> w = Washout()                     # default platform and parameters, 1 kHz
>>> pose = w.step([0.0, 0.0, 9.80665], [0.0, 0.0, 0.0])   # at rest: home
>>> poses = Washout().run(t, f, w)    # (N, 6) for N samples of f (N, 3), w (N, 3)
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from . import config as cfg
from . import model, resources

DEFAULT_PLATFORM = resources.default_platform()
AXES = ("x", "y", "z", "roll", "pitch", "yaw")
#: Telemetry CSV columns (the header line is required).
TELEMETRY_COLUMNS = ("t", "fx", "fy", "fz", "wx", "wy", "wz")
#: Pose CSV columns: hs_sim's ``play`` files and streamed targets.
POSE_COLUMNS = ("t", "x", "y", "z", "roll", "pitch", "yaw")


@dataclass(frozen=True)
class WashoutParams:
    """Parameters of the classical washout (defaults for the default
    platform, see docs/explanation/cueing.md). Per-axis tuples are (x, y, z) for the
    translation and (roll, pitch, yaw) for the rotation."""

    #: Scale of the specific force (less gravity) fed to the translation path.
    translation_scale: tuple[float, float, float] = (0.4, 0.4, 0.4)
    #: Break frequency of the second-order high pass, rad/s.
    translation_omega: tuple[float, float, float] = (3.0, 3.0, 4.0)
    #: Its damping ratio.
    translation_zeta: tuple[float, float, float] = (1.0, 1.0, 1.0)
    #: Break frequency of the first-order high pass (the washout to home), rad/s.
    translation_washout: tuple[float, float, float] = (0.5, 0.5, 0.5)
    #: Scale of the longitudinal and lateral specific force fed to the tilt.
    tilt_scale: float = 0.8
    #: Break frequency of the tilt's second-order low pass, rad/s.
    tilt_omega: float = 4.0
    #: Its damping ratio.
    tilt_zeta: float = 1.0
    #: Tilt rate limit, rad/s (4 deg/s, about the threshold of rotation perception).
    tilt_rate_max: float = math.radians(4.0)
    #: Largest tilt angle, rad (roll and pitch each).
    tilt_max: float = 0.25
    #: Scale of the angular rates fed to the rotation path (roll, pitch, yaw).
    rotation_scale: tuple[float, float, float] = (0.5, 0.5, 0.5)
    #: Break frequency of the rotation's second-order high pass, rad/s.
    rotation_omega: tuple[float, float, float] = (1.5, 1.5, 1.0)
    #: Its damping ratio.
    rotation_zeta: tuple[float, float, float] = (1.0, 1.0, 1.0)
    #: Poses are clipped to this fraction of the workspace box (last resort).
    margin: float = 0.95

    def as_dict(self) -> dict:
        return asdict(self)


def _expm(a: np.ndarray) -> np.ndarray:
    """Matrix exponential: scaling and squaring with a Taylor series (the
    matrices here are small and their norm is well below 1 after scaling)."""
    norm = float(np.abs(a).sum(axis=1).max()) if a.size else 0.0
    k = max(0, int(math.ceil(math.log2(norm))) + 1) if norm > 0.5 else 0
    s = a / (2.0 ** k)
    out = np.eye(len(a))
    term = np.eye(len(a))
    for n in range(1, 20):
        term = term @ s / n
        out = out + term
    for _ in range(k):
        out = out @ out
    return out


def _discretise(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of x' = A x + B u."""
    n, m = b.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n] = a
    big[:n, n:] = b
    e = _expm(big * dt)
    return e[:n, :n], e[:n, n:]


def _companion(den: list[float]) -> np.ndarray:
    """A of the controllable canonical form of 1 / den(s) (den monic, highest first)."""
    n = len(den) - 1
    a = np.zeros((n, n))
    a[:-1, 1:] = np.eye(n - 1)
    a[-1, :] = -np.asarray(den[::-1][:-1])
    return a


@dataclass
class _Linear:
    """The washout's linear filters as one discrete state-space system:
    inputs u (8,) = scaled translational acceleration (3), scaled f_x, f_y
    for the tilt (2), scaled angular rate (3); outputs y (8,) = position
    (3), low-passed f_x, f_y (2), high-passed attitude (3)."""

    ad: np.ndarray
    bd: np.ndarray
    c: np.ndarray

    @staticmethod
    def build(p: WashoutParams, dt: float) -> "_Linear":
        blocks = []  # (A, B column, C row)
        for k in range(3):  # s / ((s^2 + 2 z w s + w^2)(s + wb))
            w, z, wb = p.translation_omega[k], p.translation_zeta[k], p.translation_washout[k]
            den = np.polymul([1.0, 2 * z * w, w * w], [1.0, wb])
            a = _companion(list(den))
            blocks.append((a, np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])))
        for _ in range(2):  # w^2 / (s^2 + 2 z w s + w^2)
            w, z = p.tilt_omega, p.tilt_zeta
            a = _companion([1.0, 2 * z * w, w * w])
            blocks.append((a, np.array([0.0, 1.0]), np.array([w * w, 0.0])))
        for k in range(3):  # s / (s^2 + 2 z w s + w^2)
            w, z = p.rotation_omega[k], p.rotation_zeta[k]
            a = _companion([1.0, 2 * z * w, w * w])
            blocks.append((a, np.array([0.0, 1.0]), np.array([0.0, 1.0])))
        n = sum(len(b[1]) for b in blocks)
        A = np.zeros((n, n))
        B = np.zeros((n, len(blocks)))
        C = np.zeros((len(blocks), n))
        i = 0
        for j, (a, b, c) in enumerate(blocks):
            m = len(b)
            A[i:i + m, i:i + m] = a
            B[i:i + m, j] = b
            C[j, i:i + m] = c
            i += m
        ad, bd = _discretise(A, B, dt)
        return _Linear(ad, bd, C)


def _check_params(p: WashoutParams) -> None:
    for name in ("translation_scale", "translation_omega", "translation_zeta", "translation_washout",
                 "rotation_scale", "rotation_omega", "rotation_zeta"):
        v = getattr(p, name)
        if len(v) != 3 or not all(math.isfinite(x) for x in v):
            raise ValueError(f"washout: {name} must be 3 finite numbers")
    positive = list(p.translation_omega) + list(p.translation_zeta) + list(p.translation_washout) \
        + list(p.rotation_omega) + list(p.rotation_zeta) + [p.tilt_omega, p.tilt_zeta, p.tilt_rate_max]
    if any(not x > 0 for x in positive):
        raise ValueError("washout: break frequencies, damping ratios and the tilt rate limit must be > 0")
    if not 0 <= p.tilt_max < math.pi / 2:
        raise ValueError("washout: tilt_max must be in [0, pi/2)")
    if not 0 < p.margin <= 1:
        raise ValueError("washout: margin must be in (0, 1]")


@dataclass
class Washout:
    """Classical washout filter. ``params`` None: :class:`WashoutParams`
    defaults; ``dt``: sample period, s (the controller's 1 ms); ``platform``:
    a :class:`stewart.config.Platform` (default config/platform_default.json)
    for ``home``, ``gravity`` and the workspace box."""

    params: WashoutParams | None = None
    dt: float = 0.001
    platform: object = None
    clipped: np.ndarray = field(init=False)   #: (6,) samples clipped per axis

    def __post_init__(self):
        if self.params is None:
            self.params = WashoutParams()
        _check_params(self.params)
        if not (math.isfinite(self.dt) and 0 < self.dt <= 0.1):
            raise ValueError("washout: dt must be in (0, 0.1] s")
        if self.platform is None:
            self.platform = cfg.load(DEFAULT_PLATFORM)
        self.home = np.asarray(self.platform.home, dtype=float)
        self.gravity = float(self.platform.gravity)
        self.lower = self.params.margin * np.asarray(self.platform.workspace_min, dtype=float)
        self.upper = self.params.margin * np.asarray(self.platform.workspace_max, dtype=float)
        self._lin = _Linear.build(self.params, self.dt)
        self.reset()

    def reset(self) -> None:
        """Back to home at rest."""
        self._x = np.zeros(self._lin.ad.shape[0])
        self._tilt = np.zeros(2)   # roll, pitch from the tilt path
        self.clipped = np.zeros(6, dtype=np.int64)

    def _inputs(self, f: np.ndarray, w: np.ndarray) -> np.ndarray:
        """(..., 3), (..., 3) -> (..., 8) inputs of the linear part."""
        p = self.params
        acc = (f - np.array([0.0, 0.0, self.gravity])) * np.asarray(p.translation_scale)
        tilt = f[..., :2] * p.tilt_scale
        rate = w * np.asarray(p.rotation_scale)
        return np.concatenate([acc, tilt, rate], axis=-1)

    def _tilt_target(self, flp: np.ndarray) -> np.ndarray:
        """Low-passed (f_x, f_y) -> (roll, pitch) that let gravity supply
        them: with Z-Y-X angles gravity gives the platform f_x = -g sin(pitch)
        and f_y = g cos(pitch) sin(roll)."""
        s = np.sin(self.params.tilt_max)
        pitch = -np.arcsin(np.clip(flp[..., 0] / self.gravity, -s, s))
        roll = np.arcsin(np.clip(flp[..., 1] / (self.gravity * np.cos(pitch)), -s, s))
        return np.stack([roll, pitch], axis=-1)

    def _pose(self, y: np.ndarray, tilt: np.ndarray) -> np.ndarray:
        cue = np.concatenate([y[..., :3], y[..., 5:7] + tilt, y[..., 7:8]], axis=-1)
        over = (cue < self.lower) | (cue > self.upper)
        self.clipped += over.reshape(-1, 6).sum(axis=0)
        return self.home + np.clip(cue, self.lower, self.upper)

    def step(self, specific_force_xyz, angular_rate_xyz) -> np.ndarray:
        """One sample: specific force (3,) m/s^2 and angular rate (3,) rad/s,
        vehicle frame -> the platform pose (6,) for this sample."""
        f = np.asarray(specific_force_xyz, dtype=float).reshape(3)
        w = np.asarray(angular_rate_xyz, dtype=float).reshape(3)
        if not (np.isfinite(f).all() and np.isfinite(w).all()):
            raise ValueError("washout: telemetry values must be finite")
        u = self._inputs(f, w)
        lin = self._lin
        # the input is held over the sample period that ends with this
        # sample: x_k = Ad x_(k-1) + Bd u_k, y_k = C x_k
        self._x = lin.ad @ self._x + lin.bd @ u
        y = lin.c @ self._x
        dmax = self.params.tilt_rate_max * self.dt
        self._tilt = self._tilt + np.clip(self._tilt_target(y[3:5]) - self._tilt, -dmax, dmax)
        return self._pose(y, self._tilt)

    def run(self, t, f, w) -> np.ndarray:
        """Poses (N, 6) for N samples: ``t`` (N,) s at the filter's ``dt``
        (checked), ``f`` and ``w`` (N, 3). Starts from the current state
        (home after construction or :meth:`reset`); the same poses as
        :meth:`step` sample by sample. The inputs are mapped to all filters
        at once; the recursion runs sample by sample over the 19 states."""
        t = np.asarray(t, dtype=float).reshape(-1)
        f = np.asarray(f, dtype=float).reshape(-1, 3)
        w = np.asarray(w, dtype=float).reshape(-1, 3)
        if not (len(t) == len(f) == len(w)):
            raise ValueError("washout: t, f and w need the same number of samples")
        if not (np.isfinite(t).all() and np.isfinite(f).all() and np.isfinite(w).all()):
            raise ValueError("washout: telemetry values must be finite")
        if len(t) > 1 and np.abs(np.diff(t) - self.dt).max() > 1e-6 + 1e-9 * np.abs(t).max():
            raise ValueError(f"washout: samples must be {self.dt} s apart (resample first)")
        u = self._inputs(f, w)
        bu = u @ self._lin.bd.T
        ad, c = self._lin.ad, self._lin.c
        xs = np.empty((len(t), len(self._x)))
        x = self._x
        for k in range(len(t)):
            x = ad @ x + bu[k]
            xs[k] = x
        self._x = x
        y = xs @ c.T
        target = self._tilt_target(y[:, 3:5])
        dmax = self.params.tilt_rate_max * self.dt
        tilt = np.empty((len(t), 2))
        cur = self._tilt.copy()
        for k in range(len(t)):
            cur = cur + np.clip(target[k] - cur, -dmax, dmax)
            tilt[k] = cur
        self._tilt = cur
        return self._pose(y, tilt)


# -- what the platform reproduces ------------------------------------------------

def platform_specific_force(poses: np.ndarray, dt: float, gravity: float = 9.80665) -> np.ndarray:
    """Specific force (N, 3) felt on the platform, in the platform's frame:
    R^T (a + (0, 0, g)) with a the second derivative of the position
    (central differences) and R the attitude (gravity tilt included)."""
    poses = np.asarray(poses, dtype=float)
    acc = np.gradient(np.gradient(poses[:, :3], dt, axis=0), dt, axis=0)
    r = model.rotation_many(poses[:, 3:])
    return np.einsum("nji,nj->ni", r, acc + np.array([0.0, 0.0, gravity]))


def lowpass_fft(x: np.ndarray, dt: float, cutoff_hz: float) -> np.ndarray:
    """Zero-phase ideal low pass along axis 0 (the mean removed first and
    added back; the ends are mirrored to avoid a jump at the wrap)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    ext = np.concatenate([x, x[::-1]], axis=0)
    spec = np.fft.rfft(ext, axis=0)
    freq = np.fft.rfftfreq(2 * n, dt)
    spec[freq > cutoff_hz] = 0
    return np.fft.irfft(spec, 2 * n, axis=0)[:n]


def figures(washout: Washout, t, f, w, poses, cutoff_hz: float = 1.0) -> dict:
    """The washout's figures for a drive. Both specific forces (z less
    gravity) go through the same zero-phase low pass at ``cutoff_hz``; then
    per axis x, y, z:

    * ``specific_force_share``: the share of the vehicle's specific force
      the platform reproduces, the projection ``<p, v> / <v, v>`` (1: all
      of it, in phase; 0.3: 30 %); ``specific_force_share_xy`` the same
      over x and y together;
    * ``specific_force_fidelity``: ``1 - rms(p - v) / rms(v)`` (1 perfect,
      0 no better than a still platform, negative worse);

    and the workspace use, per axis the largest cue as a fraction of that
    side's limit; the leg stroke use (largest |L - mid| / half stroke); the
    largest leg speed; the clipped samples."""
    dt = washout.dt
    f = np.asarray(f, dtype=float)
    fp = platform_specific_force(poses, dt, washout.gravity)
    g = np.array([0.0, 0.0, washout.gravity])
    vl = lowpass_fft(f - g, dt, cutoff_hz)
    pl = lowpass_fft(fp - g, dt, cutoff_hz)
    share, fidelity = {}, {}
    for k, a in enumerate("xyz"):
        vv = float(np.dot(vl[:, k], vl[:, k]))
        share[a] = float(np.dot(pl[:, k], vl[:, k])) / vv if vv > 1e-9 else None
        fidelity[a] = (1.0 - math.sqrt(float(np.dot(pl[:, k] - vl[:, k], pl[:, k] - vl[:, k])) / vv)
                       if vv > 1e-9 else None)
    vall = float(np.sum(vl[:, :2] * vl[:, :2]))
    cue = np.asarray(poses, dtype=float) - washout.home
    lo = np.asarray(washout.platform.workspace_min, dtype=float)
    hi = np.asarray(washout.platform.workspace_max, dtype=float)
    use = np.maximum(np.where(hi > 0, cue.max(axis=0).clip(0) / np.where(hi > 0, hi, 1), 0),
                     np.where(lo < 0, cue.min(axis=0).clip(None, 0) / np.where(lo < 0, lo, -1), 0))
    lengths = model.leg_lengths_many(washout.platform, poses[::10])
    pf = washout.platform
    mid = 0.5 * (pf.leg_length_min + pf.leg_length_max)
    half = 0.5 * (pf.leg_length_max - pf.leg_length_min)
    vel = np.abs(np.diff(model.leg_lengths_many(pf, poses), axis=0)).max() / dt if len(poses) > 1 else 0.0
    return {"cutoff_hz": cutoff_hz, "specific_force_share": share,
            "specific_force_share_xy": float(np.sum(pl[:, :2] * vl[:, :2])) / vall if vall > 1e-9 else None,
            "specific_force_fidelity": fidelity,
            "workspace_use": dict(zip(AXES, (float(u) for u in use))),
            "leg_stroke_use": float(np.abs(lengths - mid).max() / half),
            "leg_length_min": float(lengths.min()), "leg_length_max": float(lengths.max()),
            "leg_velocity_max": float(vel),
            "clipped": dict(zip(AXES, (int(c) for c in washout.clipped)))}


# -- a deterministic synthetic drive ---------------------------------------------

def _ramp(t, t0, t1, rise=0.4):
    """1 between t0 and t1 with raised-cosine edges of ``rise`` s, else 0."""
    up = np.clip((t - t0) / rise, 0, 1)
    down = np.clip((t1 - t) / rise, 0, 1)
    return (0.5 - 0.5 * np.cos(np.pi * up)) * (0.5 - 0.5 * np.cos(np.pi * down))


def synthetic_drive(duration: float = 60.0, dt: float = 0.001, severity: float = 1.0,
                    gravity: float = 9.80665):
    """A deterministic drive (no random numbers): accelerate, cruise, brake,
    a left and a right corner, bumps, a lane change, a hard stop.
    ``severity`` scales every acceleration and rate (1: brisk road car;
    1.5: aggressive). Returns t (N,), f (N, 3) specific force with gravity,
    w (N, 3) angular rate (vehicle frame)."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    ax = 3.5 * _ramp(t, 2, 8) - 6.0 * _ramp(t, 12, 15) + 2.5 * _ramp(t, 17, 22) \
        - 8.0 * _ramp(t, 50, 52.5)
    ay = 5.0 * _ramp(t, 25, 31) - 5.0 * _ramp(t, 34, 39)
    ay += 3.0 * np.sin(2 * np.pi * 0.4 * (t - 42)) * _ramp(t, 42, 47, 0.2)   # lane changes
    yaw_rate = 0.35 * _ramp(t, 25, 31) - 0.35 * _ramp(t, 34, 39)
    roll_rate = np.gradient(0.04 * ay / 5.0, dt)          # body roll in corners
    pitch_rate = np.gradient(-0.02 * ax / 5.0, dt)        # dive and squat
    bumps = _ramp(t, 19, 24, 0.2) * (1.5 * np.sin(2 * np.pi * 1.3 * t) + 0.8 * np.sin(2 * np.pi * 7.0 * t))
    bumps += 4.0 * np.exp(-((t - 40.0) / 0.05) ** 2) - 3.0 * np.exp(-((t - 40.3) / 0.05) ** 2)
    f = np.stack([ax, ay, gravity + bumps], axis=1) * np.array([severity, severity, 1.0])
    f[:, 2] = gravity + severity * bumps
    w = np.stack([roll_rate, pitch_rate, yaw_rate], axis=1) * severity
    return t, f, w


# -- files -------------------------------------------------------------------------

def read_telemetry(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Telemetry CSV with the header ``t,fx,fy,fz,wx,wy,wz`` (any order, more
    columns ignored): t s strictly increasing, f m/s^2 (specific force,
    gravity included), w rad/s. ValueError naming the line for anything else."""
    path = Path(path)
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        text = fh.read().splitlines()
    rows = [(n, ln) for n, ln in enumerate(text, start=1) if ln.strip()]
    if not rows:
        raise ValueError(f"{path}: empty file")
    names = [c.strip() for c in rows[0][1].split(",")]
    missing = [c for c in TELEMETRY_COLUMNS if c not in names]
    if missing:
        raise ValueError(f"{path}: line {rows[0][0]}: header lacks column(s) {', '.join(missing)} "
                         f"(expected {','.join(TELEMETRY_COLUMNS)})")
    idx = [names.index(c) for c in TELEMETRY_COLUMNS]
    data = np.empty((len(rows) - 1, 7))
    for k, (n, ln) in enumerate(rows[1:]):
        parts = ln.split(",")
        try:
            vals = [float(parts[i]) for i in idx]
        except (ValueError, IndexError):
            raise ValueError(f"{path}: line {n}: expected numbers in columns "
                             f"{','.join(TELEMETRY_COLUMNS)}: {ln.strip()[:80]}") from None
        if not all(math.isfinite(v) for v in vals):
            raise ValueError(f"{path}: line {n}: value not finite")
        if k and vals[0] <= data[k - 1, 0]:
            raise ValueError(f"{path}: line {n}: t {vals[0]:g} s does not increase")
        data[k] = vals
    if len(data) < 2:
        raise ValueError(f"{path}: fewer than two samples")
    return data[:, 0], data[:, 1:4], data[:, 4:7]


def resample(t, f, w, dt: float):
    """Linear interpolation onto ``t[0] + k dt``; returns t from 0."""
    t = np.asarray(t, dtype=float)
    tn = t[0] + np.arange(int(math.floor((t[-1] - t[0]) / dt + 1e-9)) + 1) * dt
    fi = np.stack([np.interp(tn, t, f[:, k]) for k in range(3)], axis=1)
    wi = np.stack([np.interp(tn, t, w[:, k]) for k in range(3)], axis=1)
    return tn - t[0], fi, wi


def write_telemetry(path: str | Path, t, f, w) -> None:
    a = np.column_stack([t, f, w])
    np.savetxt(path, a, delimiter=",", header=",".join(TELEMETRY_COLUMNS), comments="",
               fmt=["%.6f"] + ["%.6f"] * 6)


def write_poses(path: str | Path, t, poses) -> None:
    """Pose CSV ``t,x,y,z,roll,pitch,yaw`` (s from the start, absolute pose
    m / rad, 1 um / 1 urad): hs_sim's ``play`` format (docs/explanation/closed_loop.md)."""
    a = np.column_stack([t, poses])
    np.savetxt(path, a, delimiter=",", header=",".join(POSE_COLUMNS), comments="",
               fmt=["%.4f"] + ["%.6f"] * 6)


def plot(path: str | Path, t, f, poses, washout: Washout, title: str = "") -> None:
    """Vehicle vs platform specific force per axis (raw and below 1 Hz) and
    the platform's cue, one PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dt = washout.dt
    fp = platform_specific_force(poses, dt, washout.gravity)
    vl, pl = lowpass_fft(f, dt, 1.0), lowpass_fft(fp, dt, 1.0)
    fig, axes = plt.subplots(4, 1, figsize=(11, 11), sharex=True)
    for k, name in enumerate(("longitudinal f_x", "lateral f_y", "vertical f_z")):
        ax = axes[k]
        ax.plot(t, f[:, k], color="0.75", lw=0.6, label="vehicle")
        ax.plot(t, vl[:, k], color="k", lw=1.4, label="vehicle < 1 Hz")
        ax.plot(t, fp[:, k], color="tab:orange", lw=0.6, alpha=0.6, label="platform")
        ax.plot(t, pl[:, k], color="tab:red", lw=1.4, label="platform < 1 Hz")
        ax.set_ylabel(f"{name}, m/s²")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=4, fontsize=8)
    cue = poses - washout.home
    ax = axes[3]
    for k, a in enumerate(AXES[:3]):
        ax.plot(t, cue[:, k], lw=1, label=f"{a}, m")
    for k, a in enumerate(AXES[3:]):
        ax.plot(t, cue[:, 3 + k], lw=1, ls="--", label=f"{a}, rad")
    ax.set_ylabel("platform cue")
    ax.set_xlabel("t, s")
    ax.legend(loc="upper right", ncol=6, fontsize=8)
    ax.grid(alpha=0.3)
    fig.suptitle(title or "classical washout: vehicle vs platform specific force")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def with_params(**kw) -> WashoutParams:
    """Default parameters with some replaced (e.g. ``tilt_rate_max=0.03``)."""
    return replace(WashoutParams(), **kw)
