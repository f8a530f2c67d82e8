# SPDX-License-Identifier: Apache-2.0
"""Geometric calibration by nonlinear least squares (numpy only).

Unknowns: every joint coordinate (base 18, platform 18), every length
sensor's zero (6) and optionally its scale (6), and the tracker's pose (6).
For each measured pose the platform's pose follows from the six readings by
forward kinematics on the current geometry; the residuals are the tracker's
target coordinates predicted minus measured. Gauss-Newton on the
identifiable subspace, with the Jacobian in closed form (implicit function
theorem through the forward kinematics).

The base frame cannot be seen from the tracker (moving every base joint
and the tracker together by one rigid motion changes no reading): it is
*defined* by the base joints' best fit to the drawing (the mean offset and
mean rotation of the base joints are zero) and those six combinations are
fixed. Any other combination whose singular value is below ``RANK_TOL`` of
the largest (a plan that does not move enough) is named and held at its
nominal value, never guessed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .kin import Geometry, Tracker, fk, ik, kabsch, pose_jacobian, rodrigues, skew

LEGS = 6
AXES = "xyz"
RANK_TOL = 1e-6        # singular value / largest below this: not identifiable
OUTLIER_SIGMA = 6.0    # a target reading this many sigma off is an outlier
# column scales: a millimetre, 100 ppm, a milliradian
_SCALE_JOINT, _SCALE_ZERO, _SCALE_GAIN, _SCALE_ROT = 1e-3, 1e-3, 1e-4, 1e-3


class CalibrationError(ValueError):
    """A calibration that cannot be made; the message names the row, pose or parameter."""


def parameter_names(fit_scale: bool) -> list[str]:
    names = [f"base_joints[{i}].{c}" for i in range(LEGS) for c in AXES]
    names += [f"platform_joints[{i}].{c}" for i in range(LEGS) for c in AXES]
    names += [f"length_zero[{i}]" for i in range(LEGS)]
    if fit_scale:
        names += [f"length_scale[{i}]" for i in range(LEGS)]
    names += [f"tracker.{c}" for c in AXES] + [f"tracker.rot_{c}" for c in AXES]
    return names


def parameter_units(fit_scale: bool) -> np.ndarray:
    u = [_SCALE_JOINT] * 36 + [_SCALE_ZERO] * 6 + ([_SCALE_GAIN] * 6 if fit_scale else [])
    return np.array(u + [_SCALE_JOINT] * 3 + [_SCALE_ROT] * 3)


@dataclass
class Data:
    """Measured poses: readings (N, 6) m, targets (N, K, 3) m in the
    tracker's frame (NaN where a target was not seen), the commanded poses
    (N, 6) (forward kinematics starts there), and the file rows (N, K) for messages."""
    readings: np.ndarray
    targets: np.ndarray
    commanded: np.ndarray
    rows: np.ndarray | None = None
    ticks: np.ndarray | None = None
    fiducials: np.ndarray | None = None       # (F, 3) base fiducials measured, tracker frame
    fiducials_base: np.ndarray | None = None  # (F, 3) their coordinates in the base frame


@dataclass
class Result:
    geometry: Geometry
    tracker: Tracker
    names: list[str]
    value: np.ndarray           # fitted minus nominal, per parameter (m, -, m, rad)
    std: np.ndarray             # standard deviation per parameter (NaN: fixed)
    singular: np.ndarray        # singular values of the scaled, gauge-fixed Jacobian
    fixed: list[str]            # the combinations held (named)
    rms: float                  # residual RMS per coordinate, m
    sigma: float                # noise used for the standard deviations, m
    outliers: list[str]
    iterations: int
    seconds: float
    used: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))


class Problem:
    """The least-squares problem of one data set around a nominal geometry."""

    def __init__(self, nominal: Geometry, targets_motion, data: Data, fit_scale: bool):
        self.nominal = nominal
        self.c = np.asarray(targets_motion, float)
        self.data = data
        self.fit_scale = fit_scale
        self.names = parameter_names(fit_scale)
        self.n = len(self.names)
        self.units = parameter_units(fit_scale)
        self.mask = np.isfinite(data.targets).all(-1)         # (N, K)

    # -- parameters ------------------------------------------------------------
    def geometry(self, theta) -> Geometry:
        g = self.nominal
        scale = g.scale + (theta[42:48] if self.fit_scale else 0.0)
        return Geometry(g.base + theta[0:18].reshape(6, 3), g.plat + theta[18:36].reshape(6, 3), g.lmin,
                        g.zero + theta[36:42], np.asarray(scale, float) * np.ones(LEGS))

    def tracker(self, theta, rot0, pos0, noise=10e-6) -> Tracker:
        t = theta[self.n - 6:self.n - 3]
        w = theta[self.n - 3:]
        return Tracker(rodrigues(w) @ rot0, pos0 + t, self.c, noise)

    @property
    def has_fiducials(self) -> bool:
        return self.data.fiducials is not None and len(self.data.fiducials) >= 3

    def gauge(self) -> np.ndarray:
        """The six base-frame combinations (rows, physical units): the mean
        offset and the mean rotation of the base joints."""
        b = self.nominal.base - self.nominal.base.mean(0)
        c = np.zeros((6, self.n))
        for i in range(LEGS):
            c[0:3, 3 * i:3 * i + 3] = np.eye(3)
            c[3:6, 3 * i:3 * i + 3] = skew(b[i])   # sum b_i x db_i
        return c

    # -- model -----------------------------------------------------------------
    def predict(self, theta, rot0, pos0):
        g = self.geometry(theta)
        trk = self.tracker(theta, rot0, pos0)
        lengths = g.length(self.data.readings)
        p0, r0 = _guess(self.data.commanded)
        p, r = fk(g, lengths, p0, r0)
        return g, trk, p, r, lengths

    def residual_jacobian(self, theta, rot0, pos0):
        g, trk, p, r, lengths = self.predict(theta, rot0, pos0)
        pred = trk.observe(p, r)
        res = pred - self.data.targets                          # (N, K, 3)
        jp, u, _ = pose_jacobian(g, p, r)                       # (N, 6, 6)
        n_pose = len(p)
        gth = np.zeros((n_pose, LEGS, self.n))
        ulocal = np.einsum("nij,nli->nlj", r, u)               # R^T u
        one_s = 1.0 + g.scale
        for i in range(LEGS):
            gth[:, i, 3 * i:3 * i + 3] = -u[:, i]
            gth[:, i, 18 + 3 * i:21 + 3 * i] = ulocal[:, i]
            gth[:, i, 36 + i] = 1.0 / one_s[i]
            if self.fit_scale:
                gth[:, i, 42 + i] = (lengths[:, i] - g.lmin) / one_s[i]
        dpose = -np.linalg.solve(jp, gth)                       # (N, 6, n)
        arm = np.einsum("nij,kj->nki", r, self.c)               # R c_k
        rt = trk.rot.T
        jac = np.zeros(res.shape + (self.n,))
        # through the pose: Rt^T (dp - [R c]x dw)
        dp = dpose[:, :3, :]
        dw = dpose[:, 3:, :]
        move = dp[:, None, :, :] - np.einsum("nkij,njm->nkim", skew(arm), dw)
        jac += np.einsum("ij,nkjm->nkim", rt, move)
        # the tracker's own pose
        world = p[:, None, :] + arm
        jac[..., self.n - 6:self.n - 3] += -rt
        jac[..., self.n - 3:] += np.einsum("ij,nkjm->nkim", rt, skew(world - trk.pos))
        res = res.reshape(-1, 3)[self.mask.reshape(-1)].reshape(-1)
        jac = jac.reshape(-1, 3, self.n)[self.mask.reshape(-1)].reshape(-1, self.n)
        if self.has_fiducials:
            f = np.asarray(self.data.fiducials_base, float)
            fres = (f - trk.pos) @ rt.T - self.data.fiducials
            fjac = np.zeros(fres.shape + (self.n,))
            fjac[..., self.n - 6:self.n - 3] = -rt
            fjac[..., self.n - 3:] = np.einsum("ij,fjm->fim", rt, skew(f - trk.pos))
            res = np.concatenate([res, fres.reshape(-1)])
            jac = np.concatenate([jac, fjac.reshape(-1, self.n)])
        return res, jac

    def target_errors(self, theta, rot0, pos0):
        """(N, K) distance of each target reading from its prediction, m."""
        g, trk, p, r, _ = self.predict(theta, rot0, pos0)
        return np.linalg.norm(trk.observe(p, r) - self.data.targets, axis=-1)


def _guess(commanded):
    from .kin import poses_to_pr
    return poses_to_pr(commanded)


def initial_tracker(nominal: Geometry, targets_motion, data: Data):
    """The tracker's pose from the nominal geometry (Kabsch over every target seen)."""
    p0, r0 = _guess(data.commanded)
    p, r = fk(nominal, nominal.length(data.readings), p0, r0)
    world = p[:, None, :] + np.einsum("nij,kj->nki", r, np.asarray(targets_motion, float))
    m = np.isfinite(data.targets).all(-1)
    if data.fiducials is not None and len(data.fiducials) >= 3:
        return kabsch(data.fiducials, data.fiducials_base)
    return kabsch(data.targets[m], world[m])


def _basis(problem: Problem):
    """Scaled coordinates with the base-frame gauge removed: theta = D Q y."""
    d = problem.units
    if problem.has_fiducials:
        return d, np.eye(problem.n)
    cg = problem.gauge() * d                     # constraint rows in scaled coordinates
    _, _, vt = np.linalg.svd(cg)
    q = vt[6:].T                                  # (n, n-6) orthonormal null space of the gauge rows
    return d, q


def name_combination(v, names, top=4) -> str:
    """A combination of parameters, its largest terms first."""
    v = v / np.max(np.abs(v))
    idx = np.argsort(-np.abs(v))[:top]
    terms = [f"{v[i]:+.2f} {names[i]}" for i in idx if abs(v[i]) > 0.05]
    more = int(np.sum(np.abs(v) > 0.05)) - len(terms)
    return " ".join(terms) + (f" (+{more} more)" if more > 0 else "")


def identifiability(problem: Problem, jac_flat):
    """(singular values, identifiable basis (n, k) in scaled coordinates,
    names of the combinations fixed)."""
    d, q = _basis(problem)
    jr = (jac_flat * d) @ q
    _, s, vt = np.linalg.svd(jr, full_matrices=False)
    keep = s > RANK_TOL * s[0]
    fixed = [] if problem.has_fiducials else [
        "base frame: mean offset x, y, z and mean rotation about x, y, z of the base joints "
        "(no base fiducials: the frame is defined by the drawing; the tracker cannot see it)"]
    for v in vt[~keep]:
        phys = d * (q @ v)
        fixed.append(name_combination(phys / d, problem.names))
    return s, q @ vt[keep].T, fixed


def solve(nominal: Geometry, targets_motion, data: Data, fit_scale=False, noise=None, iterations=20,
          outlier_sigma=OUTLIER_SIGMA) -> Result:
    """Calibrates; raises CalibrationError for data that cannot give an
    answer (too few equations, forward kinematics failing, too many outliers)."""
    t0 = time.process_time()
    problem = Problem(nominal, targets_motion, data, fit_scale)
    n_eq = int(problem.mask.sum()) * 3
    if n_eq < problem.n:
        raise CalibrationError(
            f"{len(data.readings)} pose(s) give {n_eq} equations for {problem.n} parameters: "
            f"measure at least {int(np.ceil(problem.n / (3 * data.targets.shape[1])))} poses "
            f"({data.targets.shape[1]} targets each); a good calibration takes 40-60")
    used = problem.mask.copy()
    outliers: list[str] = []
    for _round in range(12):   # one reading out per round: an outlier smears into its neighbours
        problem.mask = used
        theta, rot0, pos0, s, fixed, it, res, jac = _gauss_newton(problem, iterations)
        err = problem.target_errors(theta, rot0, pos0)
        sigma_hat = _robust_sigma(err[used])
        lim = outlier_sigma * (noise if noise else sigma_hat)
        bad = used & (err > lim)
        if not bad.any():
            break
        worst = np.unravel_index(np.argmax(np.where(used, err, 0.0)), err.shape)
        bad = np.zeros_like(bad)
        bad[worst] = True
        for n_, k_ in zip(*np.nonzero(bad)):
            where = f"row {int(data.rows[n_, k_])}" if data.rows is not None else "reading"
            outliers.append(f"{where} (pose {n_ + 1}, target {k_ + 1}): {err[n_, k_] * 1e6:.0f} um off, "
                            f"{err[n_, k_] / (lim / outlier_sigma):.0f} sigma: outlier, left out")
        used = used & ~bad
        if (~used & np.isfinite(data.targets).all(-1)).sum() > 0.1 * used.size:
            raise CalibrationError("more than 10 % of the target readings are outliers:\n  "
                                   + "\n  ".join(outliers[:10]))
    rms = float(np.sqrt(np.mean(res ** 2)))
    dof = max(1, len(res) - int(np.sum(s > RANK_TOL * s[0])))
    sigma = float(noise) if noise else float(np.sqrt(np.sum(res ** 2) / dof))
    std = _std(problem, jac, sigma)
    g = problem.geometry(theta)
    return Result(g, problem.tracker(theta, rot0, pos0, sigma), problem.names, theta.copy(),
                  std, s, fixed, rms, sigma, outliers, it, time.process_time() - t0, used)


def _robust_sigma(err):
    """Per-coordinate noise from the median target error (chi with 3 dof: median 1.538 sigma)."""
    return float(np.median(err) / 1.5382) if len(err) else 0.0


def _gauss_newton(problem: Problem, iterations):
    theta = np.zeros(problem.n)
    rot0, pos0 = initial_tracker(problem.nominal, problem.c, problem.data)
    d, q = _basis(problem)
    s, fixed, basis = None, [], None
    for it in range(1, iterations + 1):
        try:
            res, jac = problem.residual_jacobian(theta, rot0, pos0)
        except RuntimeError as e:
            raise CalibrationError(f"the geometry diverges: {e}") from None
        jf, rf = jac, res
        if basis is None:
            s, basis, fixed = identifiability(problem, jf)
        a = (jf * d) @ basis
        y, *_ = np.linalg.lstsq(a, -rf, rcond=None)
        step = d * (basis @ y)
        theta = theta + step
        if np.max(np.abs(step / d)) < 1e-7:
            break
    res, jac = problem.residual_jacobian(theta, rot0, pos0)
    return theta, rot0, pos0, s, fixed, it, res, jac


def _std(problem: Problem, jf, sigma):
    d, q = _basis(problem)
    s, basis, fixed = identifiability(problem, jf)
    a = (jf * d) @ basis
    cov_y = np.linalg.inv(a.T @ a) * sigma ** 2
    t = d[:, None] * basis
    var = np.einsum("ij,jk,ik->i", t, cov_y, t)
    return np.sqrt(np.maximum(var, 0.0))
