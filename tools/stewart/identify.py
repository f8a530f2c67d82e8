# SPDX-License-Identifier: Apache-2.0
"""Identification of the payload and the cylinder friction from a logged run.

The dynamics of the float64 model (:mod:`stewart.model`) are linear in 22
parameters once the motion is known: the 10 rigid-body parameters of the
moving mass (mass m, first moments m c, inertia about o' in the motion
frame) and per cylinder a viscous and a Coulomb coefficient. The leg masses
are known (taken from the config). The legs' moments of inertia across the
leg are held at the config's values or, with ``leg_inertia=True``, identified
as a 23rd parameter: their sum I_c + I_r, the only combination the
platform's forces see (docs/explanation/identification.md "Leg inertia").
From a run's measured leg lengths this
module computes the pose (forward kinematics), its rates and accelerations
(zero-phase Savitzky-Golay differentiation), writes every cylinder force as
a row of a linear regression, and solves it by least squares, with standard
errors and an observability test. It also plans an excitation that makes
every parameter observable. Theory and choices: docs/explanation/identification.md.

Python API::

    res = identify_log("run.log", platform)          # or identify_motion(...)
    print(format_result(res))
    new = updated_config(raw_config_dict, res)       # dict for json.dump
    plan = plan_excitation(platform)                 # t, poses, checks
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import model

LEGS = 6
TICK_S = 1e-3

#: The parameters in the order of the regressor's columns: the rigid-body
#: part (inertia about o', motion axes) and the friction per leg.
THETA_NAMES = (["mass", "m*cx", "m*cy", "m*cz", "Io_xx", "Io_xy", "Io_xz", "Io_yy", "Io_yz", "Io_zz"]
               + [f"viscous_friction[{i}]" for i in range(LEGS)]
               + [f"coulomb_friction[{i}]" for i in range(LEGS)])
N_RIGID = 10
N_THETA = N_RIGID + 2 * LEGS

#: The reported parameters (inertia about the centre of mass), with units.
REPORT_NAMES = (["mass", "center_of_mass x", "center_of_mass y", "center_of_mass z",
                 "inertia Ixx", "inertia Ixy", "inertia Ixz", "inertia Iyy", "inertia Iyz", "inertia Izz"]
                + [f"viscous_friction leg {i + 1}" for i in range(LEGS)]
                + [f"coulomb_friction leg {i + 1}" for i in range(LEGS)])
REPORT_UNITS = ["kg", "m", "m", "m"] + ["kg m^2"] * 6 + ["N s/m"] * LEGS + ["N"] * LEGS

#: What motion a parameter needs (for the refusal's reason).
HINTS = (["heave (z) acceleration",
          "pitch tilt or surge/heave acceleration",
          "roll tilt or sway/heave acceleration",
          "roll or pitch tilt, or surge/sway acceleration",
          "roll angular acceleration",
          "simultaneous roll and pitch motion",
          "simultaneous roll and yaw motion",
          "pitch angular acceleration",
          "simultaneous pitch and yaw motion",
          "yaw angular acceleration"]
         + [f"leg {i + 1} moving at a range of speeds" for i in range(LEGS)]
         + [f"leg {i + 1} moving in both directions" for i in range(LEGS)])

#: The optional 23rd parameter (``leg_inertia=True``): the barrel's and the
#: rod's moments of inertia across the leg, summed (the same for every leg).
LEG_INERTIA_NAME = "leg inertia I_c + I_r"
LEG_INERTIA_HINT = "the legs swinging (surge, sway and yaw accelerations)"
#: The standard error accepted for it: this share of a 95 kg leg's (the
#: default's barrel and rod) inertia as thin rods over the longest leg, at
#: least 1 kg m^2.
LEG_INERTIA_SE_SHARE = 0.05

#: Condition number of the column-scaled regressor above which the
#: regression is called rank deficient.
COND_MAX = 1.0e6
#: Rows per parameter below which nothing is estimated.
MIN_ROWS_PER_PARAM = 20

#: Defaults of the offline differentiation: Savitzky-Golay half window
#: (ticks) and polynomial order.
SG_HALF = 50
SG_ORDER = 4


class IdentifyError(ValueError):
    """The log or the excitation cannot give the parameters; the message says why."""


class Unobservable(IdentifyError):
    """A parameter the excitation does not determine."""

    def __init__(self, parameter: str, reason: str):
        super().__init__(f"{parameter}: unobservable: {reason}")
        self.parameter = parameter
        self.reason = reason


def min_leg_rate(platform) -> float:
    """Default threshold |L'| > v_min for a row to enter the regression
    (m/s): 10 mm/s, and at least three Stribeck velocities and two Coulomb
    smoothing velocities of the config, so that the break-away excess has
    decayed and the Coulomb term is at its level."""
    hyd = getattr(platform, "hydraulic", None) or {}
    return max(0.01, 3.0 * float(hyd.get("stribeck_velocity", 0.0)),
               2.0 * float(hyd.get("coulomb_velocity", 0.0)))


def se_limits(platform, leg_inertia: bool = False) -> np.ndarray:
    """The largest standard error each reported parameter may have (same
    order as REPORT_NAMES): 0.5 % of the config's mass, 2.5 mm for the centre
    of mass, 2.5 % of the config's mean principal inertia for every inertia
    element, 5 % of the config's friction (at least 150 N s/m and 20 N);
    with ``leg_inertia`` the legs' inertia's (LEG_INERTIA_SE_SHARE)."""
    inertia = np.asarray(platform.inertia, float)
    scale_i = float(np.trace(inertia)) / 3.0
    hyd = getattr(platform, "hydraulic", None) or {}
    cv = np.asarray(hyd.get("viscous_friction", [0.0] * LEGS), float)
    fc = np.asarray(hyd.get("coulomb_friction", [0.0] * LEGS), float)
    out = np.concatenate([[0.005 * platform.mass], [2.5e-3] * 3, [0.025 * scale_i] * 6,
                          np.maximum(0.05 * cv, 150.0), np.maximum(0.05 * fc, 20.0)])
    if not leg_inertia:
        return out
    m_c, _, m_r, _ = model.leg_masses(platform)
    lmax = float(getattr(platform, "leg_length_max", 3.0))
    return np.append(out, max(LEG_INERTIA_SE_SHARE * (m_c + m_r) * lmax ** 2 / 12.0, 1.0))


# -- offline differentiation -------------------------------------------------------

def sg_kernels(half: int, order: int) -> np.ndarray:
    """(3, 2 half + 1): the least-squares polynomial fit of ``order`` to a
    window of 2 half + 1 unit-spaced samples, evaluated at its centre: value,
    first and second derivative (per sample, per sample^2). Correlating a
    signal with a row (np.convolve with the row reversed) applies it; the
    window is symmetric, so there is no phase lag."""
    if order < 2 or half < order:
        raise ValueError(f"Savitzky-Golay: need order >= 2 and half window >= order, got {order}, {half}")
    j = np.arange(-half, half + 1, dtype=float) / half     # scaled for conditioning
    vander = j[:, None] ** np.arange(order + 1)[None, :]
    pinv = np.linalg.pinv(vander)            # coefficients of the fit = pinv @ samples
    return np.array([pinv[0], pinv[1] / half, 2.0 * pinv[2] / (half * half)])


def differentiate(x: np.ndarray, dt: float, half: int = SG_HALF, order: int = SG_ORDER):
    """Zero-phase smoothing and differentiation of uniformly sampled rows of
    x (N, ...): returns (value, rate, acceleration), NaN in the first and
    last ``half`` rows (no full window there)."""
    x = np.asarray(x, float)
    k = sg_kernels(half, order)
    n = x.shape[0]
    out = [np.full(x.shape, np.nan) for _ in range(3)]
    if n < 2 * half + 1:
        return tuple(out)
    flat = x.reshape(n, -1)
    for d, scale in enumerate((1.0, 1.0 / dt, 1.0 / (dt * dt))):
        o = out[d].reshape(n, -1)
        for c in range(flat.shape[1]):
            o[half:n - half, c] = np.convolve(flat[:, c], k[d][::-1], mode="valid") * scale
    return tuple(out)


def contiguous_runs(ticks: np.ndarray, ok: np.ndarray, step: int = 1) -> list[tuple[int, int]]:
    """[start, end) index ranges where ok holds on consecutive samples,
    ``step`` ticks apart."""
    runs = []
    start = None
    for i in range(len(ticks)):
        good = bool(ok[i]) and (start is None or ticks[i] == ticks[i - 1] + step)
        if start is not None and not good:
            runs.append((start, i))
            start = None
        if start is None and ok[i]:
            start = i
    if start is not None:
        runs.append((start, len(ticks)))
    return runs


# -- forward kinematics for a whole log ------------------------------------------

def _euler_to_body(rpy: np.ndarray) -> np.ndarray:
    """E (..., 3, 3) with w_body = E rpy' (eq 10)."""
    sf, cf = np.sin(rpy[..., 0]), np.cos(rpy[..., 0])
    st, ct = np.sin(rpy[..., 1]), np.cos(rpy[..., 1])
    one, zero = np.ones_like(sf), np.zeros_like(sf)
    return np.stack([np.stack([one, zero, -st], -1),
                     np.stack([zero, cf, sf * ct], -1),
                     np.stack([zero, -sf, cf * ct], -1)], -2)


def forward_kinematics_many(platform, lengths: np.ndarray, guess: np.ndarray, tol: float = 1e-10,
                            max_iterations: int = 30):
    """Poses (N, 6) from leg lengths (N, 6): Newton-Raphson for all rows at
    once on the pose parameters, Jacobian rows [u_i, ((R a_i) x u_i)^T R E]
    (E: Euler rates -> body angular velocity). Returns (poses, converged
    mask); a row that does not converge keeps NaN."""
    lengths = np.asarray(lengths, float)
    x = np.array(guess, dtype=float, copy=True)
    n = lengths.shape[0]
    done = np.zeros(n, bool)
    active = np.all(np.isfinite(lengths), axis=1) & np.all(np.isfinite(x), axis=1)
    a = np.asarray(platform.platform_joints, float)
    b = np.asarray(platform.base_joints, float)
    for _ in range(max_iterations):
        idx = np.nonzero(active & ~done)[0]
        if idx.size == 0:
            break
        xa = x[idx]
        rot = model.rotation_many(xa[:, 3:])
        arms = np.einsum("njk,ik->nij", rot, a)
        legs = arms + xa[:, None, :3] - b
        ln = np.linalg.norm(legs, axis=-1)
        u = legs / ln[..., None]
        rot_e = rot @ _euler_to_body(xa[:, 3:])
        jac = np.concatenate([u, np.einsum("nik,nkj->nij", np.cross(arms, u), rot_e)], axis=-1)
        r = ln - lengths[idx]
        try:
            step = np.linalg.solve(jac, r[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.stack([np.linalg.lstsq(j, rr, rcond=None)[0] for j, rr in zip(jac, r)])
        bad = ~np.all(np.isfinite(step), axis=1)
        step[bad] = 0.0
        active[idx[bad]] = False
        x[idx] = xa - step
        done[idx] = ~bad & (np.max(np.abs(step), axis=1) < tol)
    out = np.full_like(x, np.nan)
    out[done] = x[done]
    return out, done


# -- the regression ------------------------------------------------------------------

def _inertia_columns(x: np.ndarray) -> np.ndarray:
    """L(x) (..., 3, 6) with I x = L(x) [Ixx, Ixy, Ixz, Iyy, Iyz, Izz] for a
    symmetric I."""
    z = np.zeros(x.shape[:-1])
    x0, x1, x2 = x[..., 0], x[..., 1], x[..., 2]
    return np.stack([np.stack([x0, x1, x2, z, z, z], -1),
                     np.stack([z, x0, z, x1, x2, z], -1),
                     np.stack([z, z, x0, z, x1, x2], -1)], -2)


def _skew(v: np.ndarray) -> np.ndarray:
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def wrench_regressor(jm: model.JointMotion, gravity: float) -> np.ndarray:
    """Y (..., 6, 10) with [force; moment about o'] = Y theta for theta =
    [m, m cx, m cy, m cz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz] (c in the motion frame,
    inertia about o' in the motion frame):

        force  = m (a + g e_z) + (S(w') + S(w)^2) R (m c)
        moment = R (L(w_b') + S(w_b) L(w_b)) I_o - S(a + g e_z) R (m c)."""
    shape = jm.acc.shape[:-1]
    y = np.zeros(shape + (6, N_RIGID))
    ag = jm.acc + np.array([0.0, 0.0, gravity])
    y[..., :3, 0] = ag
    sw = _skew(jm.w)
    y[..., :3, 1:4] = (_skew(jm.wd) + sw @ sw) @ jm.rot
    y[..., 3:, 1:4] = -_skew(ag) @ jm.rot
    lw = _inertia_columns(jm.wd_body) + _skew(jm.w_body) @ _inertia_columns(jm.w_body)
    y[..., 3:, 4:] = jm.rot @ lw
    return y


@dataclass
class Regression:
    """The stacked regression y = X theta + noise, one row per (tick, leg)."""
    x: np.ndarray          #: (rows, 22), or (rows, 23) with the legs' inertia
    y: np.ndarray          #: (rows,)
    tick_index: np.ndarray  #: (rows,) index into the motion arrays
    leg: np.ndarray        #: (rows,) 0..5
    rate: np.ndarray       #: (rows,) leg rate, m/s


def without_leg_inertia(platform):
    """A shallow copy of ``platform`` whose legs have no moment of inertia."""
    out = copy.copy(platform)
    out.hydraulic = dict(getattr(platform, "hydraulic", None) or {}, cylinder_inertia=0.0, rod_inertia=0.0)
    return out


def build_regression(platform, pose, rate6, acc6, force, min_rate: float, leg_inertia: bool = False) -> Regression:
    """Rows of the regression from the motion (N, 6 each: pose, pose rates,
    pose accelerations) and the measured cylinder forces (N, 6, pressure
    force = F_i + friction). A row (tick, leg) is used when everything is
    finite and |L_i'| > min_rate. The legs' moments of inertia are the
    config's (known, like the leg masses) or, with ``leg_inertia``, a 23rd
    column: the cylinder forces per kg m^2 of I_c + I_r."""
    pose, rate6, acc6, force = (np.asarray(a, float) for a in (pose, rate6, acc6, force))
    n_theta = N_THETA + int(leg_inertia)
    good_tick = np.all(np.isfinite(np.concatenate([pose, rate6, acc6], axis=1)), axis=1)
    ti = np.nonzero(good_tick)[0]
    if ti.size == 0:
        return Regression(np.zeros((0, n_theta)), np.zeros(0), np.zeros(0, int), np.zeros(0, int), np.zeros(0))
    if leg_inertia:
        platform = without_leg_inertia(platform)
    jm = model.joint_motion(platform, pose[ti], rate6[ti, :3], rate6[ti, 3:], acc6[ti, :3], acc6[ti, 3:])
    h = model.leg_joint_forces(platform, jm)
    known = np.concatenate([h.sum(axis=-2), np.cross(jm.arms, h).sum(axis=-2)], axis=-1)
    y_w = wrench_regressor(jm, float(platform.gravity))
    cols = [y_w, known[..., None]]                                      # (n, 6, 11)
    if leg_inertia:
        hi = model.leg_inertia_forces(jm)
        cols.append(np.concatenate([hi.sum(axis=-2), np.cross(jm.arms, hi).sum(axis=-2)], axis=-1)[..., None])
    z = np.linalg.solve(model.force_matrix_of(jm), np.concatenate(cols, axis=-1))  # cylinder space
    v = jm.rates
    use = (np.abs(v) > min_rate) & np.isfinite(force[ti])
    t_rows, legs = np.nonzero(use)
    rows = t_rows.size
    x = np.zeros((rows, n_theta))
    x[:, :N_RIGID] = z[t_rows, legs, :N_RIGID]
    hyd = getattr(platform, "hydraulic", None) or {}
    vc = float(hyd.get("coulomb_velocity", 1.0e-3))
    vr = v[t_rows, legs]
    x[np.arange(rows), N_RIGID + legs] = vr
    x[np.arange(rows), N_RIGID + LEGS + legs] = model.coulomb_shape(vr / vc)
    if leg_inertia:
        # H = H_0 + (I_c + I_r) H_1: its share moves to the regressor
        x[:, N_THETA] = -z[t_rows, legs, N_RIGID + 1]
    # F_meas = A^-1 (Y theta - H) + friction  ->  F_meas + A^-1 H = X theta
    y = force[ti][t_rows, legs] + z[t_rows, legs, N_RIGID]
    return Regression(x, y, ti[t_rows], legs, vr)


# -- solving and judging ---------------------------------------------------------------

def derived(theta: np.ndarray) -> np.ndarray:
    """The reported parameters from theta: m, c = (m c)/m, the inertia about
    the centre of mass (I_G = I_o - m (|c|^2 1 - c c^T)), friction."""
    m = theta[0]
    c = theta[1:4] / m
    io = inertia_matrix(theta[4:10])
    ig = io - m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.concatenate([[m], c, ig[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]], theta[N_RIGID:]])


def inertia_matrix(six) -> np.ndarray:
    xx, xy, xz, yy, yz, zz = six
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def theta_of(platform, leg_inertia: bool = False) -> np.ndarray:
    """theta of a config (inertia moved from the centre of mass to o'; with
    ``leg_inertia`` the legs' I_c + I_r last)."""
    m = float(platform.mass)
    c = np.asarray(getattr(platform, "center_of_mass", None) or [0.0] * 3, float)
    io = np.asarray(platform.inertia, float) + m * (c @ c * np.eye(3) - np.outer(c, c))
    hyd = getattr(platform, "hydraulic", None) or {}
    out = np.concatenate([[m], m * c, io[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]],
                          hyd.get("viscous_friction", [0.0] * LEGS), hyd.get("coulomb_friction", [0.0] * LEGS)])
    return np.append(out, sum(model.leg_inertias(platform))) if leg_inertia else out


@dataclass
class Result:
    """What :func:`solve` found."""
    theta: np.ndarray            #: (22,) estimate
    cov_theta: np.ndarray        #: (22, 22)
    values: np.ndarray           #: (22,) reported parameters (REPORT_NAMES)
    se: np.ndarray               #: (22,) their standard errors
    se_limit: np.ndarray         #: (22,) the largest standard error accepted
    condition: float             #: condition number of the column-scaled regressor
    rows: int
    ticks: int
    residual_rms: float          #: N
    min_rate: float
    info: dict[str, Any] = field(default_factory=dict)
    names: tuple = tuple(REPORT_NAMES)  #: of values (the legs' inertia last when identified)
    units: tuple = tuple(REPORT_UNITS)


def _tables(n_theta: int) -> tuple[tuple, tuple, tuple]:
    """(names, units, hints) of the n_theta parameters (22, or 23 with the legs' inertia)."""
    extra = n_theta - N_THETA
    return (tuple(REPORT_NAMES) + (LEG_INERTIA_NAME,) * extra, tuple(REPORT_UNITS) + ("kg m^2",) * extra,
            tuple(HINTS) + (LEG_INERTIA_HINT,) * extra)


def solve(reg: Regression, platform, min_rate: float, check: bool = True) -> Result:
    """Least squares on the column-scaled regressor; standard errors from
    the residual variance. With ``check`` raises :class:`Unobservable` for
    the first parameter the data do not determine (rows, rank, condition,
    standard error, in that order)."""
    n, n_theta = reg.x.shape
    names, units, hints = _tables(n_theta)
    if check:
        if n < MIN_ROWS_PER_PARAM * n_theta:
            raise IdentifyError(f"only {n} usable rows (ticks x moving legs) in the log; at least "
                                f"{MIN_ROWS_PER_PARAM * n_theta} are needed (running, |leg rate| > "
                                f"{min_rate:g} m/s)")
        for i in range(LEGS):
            v = reg.rate[reg.leg == i]
            for sign, word in ((1, "extending"), (-1, "retracting")):
                cnt = int(np.sum(sign * v > 0))
                if cnt < MIN_ROWS_PER_PARAM:
                    raise Unobservable(REPORT_NAMES[N_RIGID + LEGS + i],
                                       f"leg {i + 1} is {word} faster than {min_rate:g} m/s in only {cnt} "
                                       f"running ticks; the log needs {HINTS[N_RIGID + LEGS + i]}")
    norms = np.linalg.norm(reg.x, axis=0)
    if check:
        for j in np.nonzero(norms == 0.0)[0]:
            raise Unobservable(names[j], f"no row of the log depends on it; the log needs {hints[j]}")
    norms = np.where(norms == 0.0, 1.0, norms)
    xs = reg.x / norms
    u, s, vt = np.linalg.svd(xs, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    if check and cond > COND_MAX:
        null = vt[-1]
        order = np.argsort(-np.abs(null))
        j, k = int(order[0]), int(order[1])
        if abs(null[k]) > 0.2 * abs(null[j]):
            why = f"the log does not separate it from {names[k]}"
        else:
            why = "the log hardly excites it"
        raise Unobservable(names[j], f"{why} (condition number {cond:.3g} of the scaled regressor, "
                           f"limit {COND_MAX:.0e}); the log needs {hints[j]}")
    s_inv = np.where(s > s[0] * 1e-15, 1.0 / s, 0.0)
    ths = vt.T @ (s_inv * (u.T @ reg.y))
    theta = ths / norms
    resid = reg.y - reg.x @ theta
    dof = max(n - n_theta, 1)
    sigma2 = float(resid @ resid) / dof
    cov_s = (vt.T * s_inv ** 2) @ vt * sigma2
    cov = cov_s / np.outer(norms, norms)
    values = derived(theta)
    jac = np.empty((n_theta, n_theta))
    for j in range(n_theta):
        step = 1e-7 * max(abs(theta[j]), 1.0)
        e = np.zeros(n_theta)
        e[j] = step
        jac[:, j] = (derived(theta + e) - derived(theta - e)) / (2 * step)
    cov_d = jac @ cov @ jac.T
    se = np.sqrt(np.maximum(np.diag(cov_d), 0.0))
    limits = se_limits(platform, n_theta > N_THETA)
    res = Result(theta, cov, values, se, limits, cond, n, int(np.unique(reg.tick_index).size),
                 math.sqrt(float(resid @ resid) / max(n, 1)), min_rate, names=names, units=units)
    if check:
        ratio = np.where(np.isfinite(se), se / limits, np.inf)
        j = int(np.argmax(ratio))
        if not ratio[j] <= 1.0:
            unit = units[j]
            what = "the log hardly excites it: " if ratio[j] > 100.0 else ""
            raise Unobservable(names[j],
                               f"{what}its standard error {se[j]:.3g} {unit} exceeds {limits[j]:.3g} {unit}; "
                               f"the log needs more {hints[j]}")
        check_physical(res)
    return res


def check_physical(res: Result) -> None:
    """A mass, inertia and friction that a body and a seal can have, else IdentifyError."""
    v = res.values
    if not v[0] > 0:
        raise IdentifyError(f"mass: estimated {v[0]:.4g} kg is not positive")
    ig = inertia_matrix(v[4:10])
    ev = np.linalg.eigvalsh(ig)
    if ev[0] <= 0:
        raise IdentifyError(f"inertia: the estimate about the centre of mass is not positive definite "
                            f"(principal moments {', '.join(f'{e:.4g}' for e in ev)} kg m^2)")
    if ev[0] + ev[1] < ev[2]:
        raise IdentifyError("inertia: the estimate violates the triangle inequality (not a rigid body)")
    for j in range(N_RIGID, v.size):
        if v[j] < -3.0 * res.se[j]:
            raise IdentifyError(f"{res.names[j]}: estimated {v[j]:.4g} {res.units[j]} is negative "
                                f"beyond three standard errors")


# -- from a log or from a motion ----------------------------------------------------

@dataclass
class Motion:
    """A run sampled every ``step`` ticks: pose, its rates and accelerations
    (NaN where unknown), measured forces, and which samples count
    (RUNNING)."""
    ticks: np.ndarray
    pose: np.ndarray
    rate: np.ndarray
    acc: np.ndarray
    force: np.ndarray
    running: np.ndarray
    step: int = 1


def motion_from_lengths(platform, ticks, lengths, force, running, guess=None,
                        half: int = SG_HALF, order: int = SG_ORDER, step: int = 1) -> Motion:
    """Forward kinematics of every sample, then zero-phase differentiation
    on each run of consecutive samples with a pose (Savitzky-Golay,
    polynomial ``order``, half window ``half`` ticks: round(half / step)
    samples, at least ``order``). ``step``: the ticks between samples (the
    drives' feedback period: 1 natively, the SYNC divider with CANopen
    drives that answer every few ticks)."""
    if step < 1:
        raise ValueError(f"motion_from_lengths: step must be >= 1 tick, got {step}")
    ticks = np.asarray(ticks, np.int64)
    lengths = np.asarray(lengths, float)
    n = ticks.size
    home = np.asarray(platform.home, float)
    g = np.tile(home, (n, 1)) if guess is None else np.asarray(guess, float).copy()
    bad = ~np.all(np.isfinite(g), axis=1)
    g[bad] = home
    pose, ok = forward_kinematics_many(platform, lengths, g)
    # A jump between consecutive ticks may be another assembly mode (a 6-6
    # platform has several for one set of lengths): solve those ticks again
    # from the previous tick's pose, in order (rare).
    for i in range(1, n):
        if ok[i] and ok[i - 1] and ticks[i] == ticks[i - 1] + step and np.max(np.abs(pose[i] - pose[i - 1])) > 5e-3:
            p, p_ok = forward_kinematics_many(platform, lengths[i:i + 1], pose[i - 1:i])
            pose[i], ok[i] = p[0], p_ok[0]
    rate = np.full((n, 6), np.nan)
    acc = np.full((n, 6), np.nan)
    smooth = np.full((n, 6), np.nan)
    h = max(int(round(half / step)), order)  # the same time window in samples
    for a, b in contiguous_runs(ticks, ok, step):
        if b - a >= 2 * h + 1:
            smooth[a:b], rate[a:b], acc[a:b] = differentiate(pose[a:b], step * TICK_S, h, order)
    return Motion(ticks, smooth, rate, acc, np.asarray(force, float), np.asarray(running, bool), step)


def identify_motion(platform, motion: Motion, min_rate: float | None = None, check: bool = True,
                    leg_inertia: bool = False) -> Result:
    """Identification from a :class:`Motion` (RUNNING ticks only); with
    ``leg_inertia`` the legs' moments of inertia too (else the config's)."""
    if min_rate is None:
        min_rate = min_leg_rate(platform)
    keep = motion.running & np.all(np.isfinite(motion.acc), axis=1)
    pose = np.where(keep[:, None], motion.pose, np.nan)
    reg = build_regression(platform, pose, motion.rate, motion.acc, motion.force, min_rate, leg_inertia)
    res = solve(reg, platform, min_rate, check)
    res.info.update(running_ticks=int(np.sum(motion.running)), differentiated_ticks=int(np.sum(keep)),
                    feedback_every_ticks=int(motion.step))
    return res


def feedback_step(ticks: np.ndarray, lengths: np.ndarray) -> int:
    """The drives' feedback period in ticks: the most common spacing of the
    ticks whose six lengths are known (1 natively; the SYNC divider with
    CANopen drives). 1 when fewer than two such ticks."""
    have = np.asarray(ticks, np.int64)[np.all(np.isfinite(lengths), axis=1)]
    gaps = np.diff(have)
    gaps = gaps[gaps > 0]
    if gaps.size == 0:
        return 1
    values, counts = np.unique(gaps, return_counts=True)
    return int(values[np.argmax(counts)])


def identify_log(log, platform, buses=None, min_rate: float | None = None,
                 half: int = SG_HALF, order: int = SG_ORDER, leg_inertia: bool = False) -> Result:
    """Reads a CAN log (as ``stewart analyze``) and identifies from its
    RUNNING ticks. Raises IdentifyError (or Unobservable) with the reason."""
    from .analysis.decode import read_log
    from .analysis.names import STATES

    data = read_log(log, buses=buses, platform=platform)
    if len(data) == 0:
        raise IdentifyError(f"{log}: no frames of the protocol in the log")
    if not np.isfinite(data.piston_area):
        raise IdentifyError("the config has no hydraulic section: the cylinder forces cannot be "
                            "computed from the pressures")
    running = data.state == STATES.index("RUNNING")
    if not running.any():
        raise IdentifyError(f"{log}: the log has no tick in which the platform is RUNNING")
    # drives that answer every few ticks (CANopen at a SYNC divider): their rows only
    step = feedback_step(data.ticks, data.length)
    rows = np.all(np.isfinite(data.length), axis=1) if step > 1 else slice(None)
    motion = motion_from_lengths(platform, data.ticks[rows], data.length[rows], data.force[rows], running[rows],
                                 guess=data.estimate[rows], half=half, order=order, step=step)
    res = identify_motion(platform, motion, min_rate, leg_inertia=leg_inertia)
    res.info.update(log=str(log), ticks_in_log=len(data), bad_frames=data.stats.bad_frames)
    return res


# -- output -------------------------------------------------------------------------

def updated_config(raw: dict, res: Result) -> dict:
    """A copy of the config dict ``raw`` with the identified mass, centre of
    mass, inertia (about the centre of mass) and friction lists, and the
    legs' moments of inertia when identified: their sum (clipped at 0)
    shared between barrel and rod as in ``raw`` (all to the barrel when
    ``raw`` has none)."""
    out = copy.deepcopy(raw)
    v = res.values
    out["mass"] = round(float(v[0]), 3)
    out["center_of_mass"] = [round(float(x), 5) for x in v[1:4]]
    ig = inertia_matrix(v[4:10])
    out["inertia"] = [[round(float(x), 2) for x in row] for row in ig]
    hyd = out.setdefault("hydraulic", {})
    hyd["viscous_friction"] = [round(float(x), 1) for x in v[N_RIGID:N_RIGID + LEGS]]
    hyd["coulomb_friction"] = [round(max(float(x), 0.0), 1) for x in v[N_RIGID + LEGS:N_THETA]]
    if v.size > N_THETA:
        total = max(float(v[N_THETA]), 0.0)
        ic, ir = float(hyd.get("cylinder_inertia", 0.0)), float(hyd.get("rod_inertia", 0.0))
        share = ic / (ic + ir) if ic + ir > 0.0 else 1.0
        hyd["cylinder_inertia"] = round(total * share, 3)
        hyd["rod_inertia"] = round(total * (1.0 - share), 3)
    hyd["viscous_friction"] = [max(x, 0.0) for x in hyd["viscous_friction"]]
    if "breakaway_friction" in hyd:
        bf = hyd["breakaway_friction"]
        bf_list = bf if isinstance(bf, list) else [bf] * LEGS
        if any(float(b) < c for b, c in zip(bf_list, hyd["coulomb_friction"])):
            # the break-away force is never below the Coulomb level
            hyd["breakaway_friction"] = [max(float(b), c) for b, c in zip(bf_list, hyd["coulomb_friction"])]
    return out


def format_result(res: Result) -> str:
    every = int(res.info.get("feedback_every_ticks", 1))
    sampled = f"samples (feedback every {every} ticks)" if every > 1 else "ticks"
    lines = [f"{res.ticks} running {sampled}, {res.rows} rows (|leg rate| > {res.min_rate:g} m/s); "
             f"residual RMS {res.residual_rms:.1f} N; condition number of the scaled regressor "
             f"{res.condition:.3g}"]
    w = max(len(n) for n in res.names)
    for name, unit, v, se in zip(res.names, res.units, res.values, res.se):
        lines.append(f"  {name:<{w}}  {v:12.5g} +- {se:9.3g} {unit}")
    return "\n".join(lines)


# -- excitation ------------------------------------------------------------------------

#: The controller's move limits that the stream filter applies per axis
#: (sp_ctrl_default_config: 0.25 m/s, 1 m/s^2, 5 m/s^3, the same in rad).
MOVE_LIMITS = (0.25, 1.0, 5.0)
#: Share of each limit the plan may use.
LIMIT_SHARE = 0.8
#: Force noise assumed when judging a plan (N): pressure noise 5 kPa on both chambers.
PLAN_FORCE_NOISE = 50.0


@dataclass
class Plan:
    t: np.ndarray        #: (N,) s from the start of the stream
    pose: np.ndarray     #: (N, 6) absolute target poses
    rate: np.ndarray
    acc: np.ndarray
    report: dict[str, Any]


def _multisine(t, freqs, phases, amps):
    arg = 2 * np.pi * freqs[None, :] * t[:, None] + phases[None, :]
    om = 2 * np.pi * freqs[None, :]
    return tuple(((amps * om ** k) * f(arg)).sum(axis=1)
                 for k, f in ((0, np.sin), (1, np.cos), (2, lambda a: -np.sin(a)), (3, lambda a: -np.cos(a))))


def plan_excitation(platform, duration: float = 60.0, fade: float = 3.0, f_min: float = 0.1,
                    f_max: float = 0.8, dt: float = TICK_S, seed: int = 1,
                    noise: float = PLAN_FORCE_NOISE) -> Plan:
    """A multi-axis multi-sine about home: each axis its own frequency lines
    (a 1/T grid between f_min and f_max, dealt to the six axes in turn, so
    no two axes share a line), velocity-flat amplitudes, random phases, faded
    in and out over ``fade`` s (a quintic ramp: velocity and acceleration
    zero at both ends) so it starts and ends at home at rest. Scaled to stay within LIMIT_SHARE of the workspace, the
    controller's move limits, the stroke (less 30 mm), leg_velocity_max and
    force_max (checked with the model on every sample); then judged like a
    log: the regressor for the config's payload must make every parameter
    observable with ``noise`` N of force noise. Raises IdentifyError if not."""
    if duration <= 2 * fade + 5.0:
        raise IdentifyError(f"excitation: duration {duration:g} s is too short (fades 2 x {fade:g} s + 5 s)")
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration + dt / 2, dt)
    period = duration - 2 * fade
    k0, k1 = max(1, int(math.ceil(f_min * period))), int(math.floor(f_max * period))
    lines = np.arange(k0, k1 + 1)
    if lines.size < 12:
        raise IdentifyError("excitation: fewer than two frequency lines per axis; widen the band or lengthen it")
    shapes = _excitation_shapes(platform, t, _fade_window(t, duration, fade), lines / period, rng)
    step = 1 if dt >= 0.005 else int(round(0.005 / dt))    # model checks every 5 ms
    gain, checks = _excitation_gain(platform, shapes, step)
    pose = np.asarray(platform.home, float) + gain * shapes[0]
    rate, acc = gain * shapes[1], gain * shapes[2]
    res, se_full = _judge_excitation(platform, pose, rate, acc, step, seed, noise)
    amp = np.max(np.abs(gain * shapes[0]), axis=0)
    report = dict(checks, gain=gain, condition=res.condition, predicted_se=se_full, amplitude=amp,
                  lines_hz=[list(lines[a::6] / period) for a in range(6)])
    return Plan(t, pose, rate, acc, report)


def _fade_window(t: np.ndarray, duration: float, fade: float) -> np.ndarray:
    """(4, N): the fade window and its first three derivatives: w = x^3 (10
    - 15 x + 6 x^2), x = tau / fade, on both ramps (velocity and
    acceleration start and end at zero), 1 between them."""
    win = np.zeros((4, t.size))
    win[0] = 1.0
    for sl, tau, sgn in ((t < fade, t, 1.0), (t > duration - fade, duration - t, -1.0)):
        x = tau[sl] / fade
        win[0, sl] = x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x)
        win[1, sl] = sgn * 30.0 * x * x * (1.0 - x) ** 2 / fade
        win[2, sl] = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / fade ** 2
        win[3, sl] = sgn * 60.0 * (1.0 - 6.0 * x + 6.0 * x * x) / fade ** 3
    return win


def _excitation_shapes(platform, t: np.ndarray, win: np.ndarray, line_hz: np.ndarray, rng) -> np.ndarray:
    """(4, N, 6): each axis' windowed multi-sine (the lines ``line_hz`` dealt
    to the axes in turn) and its derivatives, scaled into LIMIT_SHARE of
    the workspace and the move limits."""
    ws_lo = np.asarray(platform.workspace_min, float)
    ws_hi = np.asarray(platform.workspace_max, float)
    pos_lim = LIMIT_SHARE * np.minimum(-ws_lo, ws_hi)
    shapes = np.zeros((4, t.size, 6))
    for axis in range(6):
        f = line_hz[axis::6]
        amps = 1.0 / (2 * np.pi * f)                          # equal velocity per line
        s = _multisine(t, f, rng.uniform(0, 2 * np.pi, f.size), amps)
        # product rule for (window * signal) and its derivatives
        d0 = win[0] * s[0]
        d1 = win[1] * s[0] + win[0] * s[1]
        d2 = win[2] * s[0] + 2 * win[1] * s[1] + win[0] * s[2]
        d3 = win[3] * s[0] + 3 * win[2] * s[1] + 3 * win[1] * s[2] + win[0] * s[3]
        peaks = [np.max(np.abs(d)) for d in (d0, d1, d2, d3)]
        lims = [pos_lim[axis]] + [LIMIT_SHARE * m for m in MOVE_LIMITS]
        scale = min(lim / pk for lim, pk in zip(lims, peaks))
        for k, d in enumerate((d0, d1, d2, d3)):
            shapes[k, :, axis] = scale * d
    return shapes


def _excitation_gain(platform, shapes: np.ndarray, step: int) -> tuple[float, dict[str, float]]:
    """(gain, the checked extremes): the largest of 1, 0.9, 0.81, ... at
    which the motion keeps the stroke (less 30 mm), LIMIT_SHARE of
    leg_velocity_max and of force_max, by the model every ``step`` samples."""
    home = np.asarray(platform.home, float)
    margin = 0.03
    vmax = LIMIT_SHARE * platform.leg_velocity_max
    fmax = LIMIT_SHARE * platform.force_max
    sub = slice(None, None, step)
    gain = 1.0
    for _ in range(40):
        pose = home + gain * shapes[0]
        jm = model.joint_motion(platform, pose[sub], gain * shapes[1][sub, :3], gain * shapes[1][sub, 3:],
                                gain * shapes[2][sub, :3], gain * shapes[2][sub, 3:])
        f = model.inverse_dynamics_many(platform, pose[sub], gain * shapes[1][sub, :3], gain * shapes[1][sub, 3:],
                                        gain * shapes[2][sub, :3], gain * shapes[2][sub, 3:])
        f = f + model.friction_force(platform, jm.rates)
        checks = {"leg_length_min": float(jm.lengths.min()), "leg_length_max": float(jm.lengths.max()),
                  "leg_rate_max": float(np.abs(jm.rates).max()), "force_max": float(np.abs(f).max())}
        if (checks["leg_length_min"] >= platform.leg_length_min + margin
                and checks["leg_length_max"] <= platform.leg_length_max - margin
                and checks["leg_rate_max"] <= vmax and checks["force_max"] <= fmax):
            return gain, checks
        gain *= 0.9
    raise IdentifyError("excitation: no scale of the motion keeps the stroke, leg rate and force limits")


def _judge_excitation(platform, pose: np.ndarray, rate: np.ndarray, acc: np.ndarray, step: int, seed: int,
                      noise: float):
    """(the solution, its standard errors for every sample) of the motion
    judged like a log, with the config's parameters and ``noise`` N of force
    noise; raises Unobservable or IdentifyError if it is not good enough."""
    sub = slice(None, None, step)
    min_rate = min_leg_rate(platform)
    f_model = model.inverse_dynamics_many(platform, pose[sub], rate[sub, :3], rate[sub, 3:], acc[sub, :3], acc[sub, 3:])
    jm = model.joint_motion(platform, pose[sub], rate[sub, :3], rate[sub, 3:], acc[sub, :3], acc[sub, 3:])
    f_model = f_model + model.friction_force(platform, jm.rates)
    noisy = f_model + np.random.default_rng(seed + 1).normal(0.0, noise, f_model.shape)
    reg = build_regression(platform, pose[sub], rate[sub], acc[sub], noisy, min_rate)
    # the check used 1 tick in `step`: a log has `step` times as many rows
    res = solve(reg, platform, min_rate, check=False)
    se_full = res.se / math.sqrt(step)
    for j in range(N_THETA):
        if not se_full[j] <= res.se_limit[j]:
            raise Unobservable(REPORT_NAMES[j], f"the planned excitation leaves a standard error of "
                               f"{se_full[j]:.3g} {REPORT_UNITS[j]} (limit {res.se_limit[j]:.3g}); "
                               f"lengthen it or widen its band")
    if res.condition > COND_MAX:
        raise IdentifyError(f"excitation: condition number {res.condition:.3g} of the planned regressor")
    return res, se_full


def write_excitation(plan: Plan, scenario_path, csv_path, csv_ref: str, csv_dt: float = 0.01) -> None:
    """The CSV (t,x,y,z,roll,pitch,yaw every ``csv_dt`` s, absolute poses) and
    the scenario that plays it: engage, STREAM, play, stop, park."""
    step = max(1, int(round(csv_dt / (plan.t[1] - plan.t[0]))))
    idx = np.arange(0, plan.t.size, step)
    if idx[-1] != plan.t.size - 1:
        idx = np.append(idx, plan.t.size - 1)
    with open(csv_path, "w", encoding="utf-8") as fh:
        fh.write("t,x,y,z,roll,pitch,yaw\n")
        for i in idx:
            fh.write(f"{plan.t[i]:.3f}," + ",".join(f"{round(v, 7) + 0.0:.7f}" for v in plan.pose[i]) + "\n")
    duration = plan.t[-1]
    text = f"""# Excitation for `stewart identify` (docs/explanation/identification.md): a
# {duration:.0f} s multi-axis multi-sine about home, streamed from {csv_ref}.
# Condition number of the planned (column-scaled) regressor: {plan.report['condition']:.3g}.
cmd ENGAGE
wait ready 120
cmd STREAM
wait running 5
mark excitation start
play {csv_ref}
mark excitation end
cmd STOP
wait ready 60
cmd PARK
wait idle 120
end
"""
    with open(scenario_path, "w", encoding="utf-8") as fh:
        fh.write(text)
