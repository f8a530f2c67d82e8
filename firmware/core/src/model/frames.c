/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/model/frames.h"

#include <stddef.h>

#include "model/model_internal.h"
#include "math/fixed_inline.h"

#define Q24_PI INT32_C(52707179)      /* pi in Q24, rounded */
#define Q24_HALF_PI INT32_C(26353589) /* pi / 2 in Q24 */

/* ---- rotations (the paper's T: rows = the inner frame's axes in outer coordinates) ---- */

static void rot_identity(sp_rot_t *r)
{
    unsigned i, j;
    for (i = 0u; i < 3u; ++i) {
        for (j = 0u; j < 3u; ++j) {
            r->t[i][j] = (i == j) ? SP_Q30_ONE : 0;
        }
    }
}

/* out = a b (at: a^T b; bt: a b^T), Q30, each entry rounded once. */
static void rot_mul(const sp_rot_t *a, int at, const sp_rot_t *b, int bt, sp_rot_t *out)
{
    unsigned i, j, k;
    sp_flags_t flags = 0u; /* products of rotations stay within [-1 - eps, 1 + eps] */
    for (i = 0u; i < 3u; ++i) {
        for (j = 0u; j < 3u; ++j) {
            int64_t s = 0;
            for (k = 0u; k < 3u; ++k) {
                int32_t x = at ? a->t[k][i] : a->t[i][k];
                int32_t y = bt ? b->t[j][k] : b->t[k][j];
                s += (int64_t)x * y;
            }
            out->t[i][j] = spi_narrow_away(s, 30u, &flags);
        }
    }
}

/* Q54 sum: v (inner coordinates, Q24) turned to outer coordinates, R v =
 * T^T v: out_c = sum_r T[r][c] v_r. */
static void acc_out(const sp_rot_t *t, const int32_t v[3], int sign, int64_t acc[3])
{
    unsigned r, c;
    for (c = 0u; c < 3u; ++c) {
        int64_t s = 0;
        for (r = 0u; r < 3u; ++r) {
            s += (int64_t)t->t[r][c] * v[r];
        }
        acc[c] += (sign < 0) ? -s : s;
    }
}

/* Q54 sum: v (outer coordinates) in inner coordinates, R^T v = T v. */
static void acc_in(const sp_rot_t *t, const int32_t v[3], int64_t acc[3])
{
    unsigned r, c;
    for (r = 0u; r < 3u; ++r) {
        int64_t s = 0;
        for (c = 0u; c < 3u; ++c) {
            s += (int64_t)t->t[r][c] * v[c];
        }
        acc[r] += s;
    }
}

/* ---- atan2 ------------------------------------------------------------------------------ */

/* atan(z) for z in [0, 1] (Q16), rad, Q24, within 1.6e-3 rad: pi/4 z +
 * z (1 - z) (0.2447 + 0.0663 z). */
static int32_t atan_coarse(int32_t z)
{
    int64_t lin = (int64_t)z * 13176795;                  /* pi/4 in Q24: Q40 */
    int64_t poly = 16037 + (((int64_t)z * 4345) >> 16);   /* 0.2447 + 0.0663 z, Q16 */
    int64_t bend = ((int64_t)z * (65536 - z)) >> 16;      /* z (1 - z), Q16 */
    return (int32_t)((lin >> 16) + ((bend * poly) >> 8)); /* Q24 */
}

sp_q24_t sp_frames_atan2(int32_t y, int32_t x)
{
    int64_t ax = (x < 0) ? -(int64_t)x : x;
    int64_t ay = (y < 0) ? -(int64_t)y : y;
    int swap = ay > ax;
    int64_t hi = swap ? ay : ax;
    int64_t lo = swap ? ax : ay;
    unsigned sh;
    int32_t a0, a, num30, den30;
    sp_q30_t s0, c0;
    sp_flags_t flags = 0u;
    if (hi == 0) {
        return 0;
    }
    /* hi into [2^29, 2^30], lo scaled alike */
    sh = spi_clz64((uint64_t)hi);
    if (sh > 34u) {
        hi <<= sh - 34u;
        lo <<= sh - 34u;
    } else {
        hi >>= 34u - sh;
        lo >>= 34u - sh;
    }
    a0 = atan_coarse((int32_t)(lo / (hi >> 16)));
    /* one Newton step: e = atan2(lo c0 - hi s0, hi c0 + lo s0), |e| < 2e-3, taken as its tangent */
    sp_sincos_q24(a0, &s0, &c0);
    num30 = (int32_t)spi_round_away(lo * c0 - hi * s0, 30u);
    den30 = (int32_t)spi_round_away(hi * c0 + lo * s0, 30u);
    a = a0 + sp_div(num30, den30, 24u, &flags);
    if (swap) {
        a = Q24_HALF_PI - a;
    }
    if (x < 0) {
        a = Q24_PI - a;
    }
    return (y < 0) ? -a : a;
}

/* roll, pitch, yaw of the paper's T (R = T^T = Rz Ry Rx). */
static void angles_of(const sp_rot_t *t, sp_q24_t rpy[3])
{
    int64_t c2 = (int64_t)t->t[0][0] * t->t[0][0] + (int64_t)t->t[0][1] * t->t[0][1];
    int32_t cp = (int32_t)sp_isqrt64((uint64_t)c2); /* Q30 */
    rpy[0] = sp_frames_atan2(t->t[1][2], t->t[2][2]);
    rpy[1] = sp_frames_atan2(-t->t[0][2], cp);
    rpy[2] = sp_frames_atan2(t->t[0][1], t->t[0][0]);
}

/* ---- preparing ---------------------------------------------------------------------------- */

static int all_zero(const sp_q24_t v[3])
{
    return (v[0] | v[1] | v[2]) == 0;
}

static int angles_ok(const sp_q24_t rpy[3])
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (rpy[k] > SP_FRAME_ANGLE_MAX || rpy[k] < -SP_FRAME_ANGLE_MAX) {
            return 0;
        }
    }
    return 1;
}

static void frames_identity(sp_frames_t *f)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        f->tool.pos[k] = 0;
        f->tool.rpy[k] = 0;
        f->work.pos[k] = 0;
        f->work.rpy[k] = 0;
    }
    rot_identity(&f->tool_rot);
    rot_identity(&f->work_rot);
    f->identity = 1u;
    f->tool_turned = 0u;
    f->work_turned = 0u;
    f->reserved = 0u;
}

sp_status_t sp_frames_prepare(const sp_pose_t *tool, const sp_pose_t *work, sp_frames_t *f)
{
    sp_q30_t sc[6];
    uint64_t d2 = 0u;
    unsigned k;
    if (f == NULL) {
        return SP_E_ARG;
    }
    frames_identity(f);
    if (tool != NULL) {
        for (k = 0u; k < 3u; ++k) {
            d2 += (uint64_t)((int64_t)tool->pos[k] * tool->pos[k]);
        }
        if (d2 > (uint64_t)((int64_t)SP_FRAME_TOOL_REACH_MAX * SP_FRAME_TOOL_REACH_MAX) || !angles_ok(tool->rpy)) {
            return SP_E_RANGE;
        }
    }
    if (work != NULL) {
        for (k = 0u; k < 3u; ++k) {
            if (work->pos[k] > SP_FRAME_WORK_REACH_MAX || work->pos[k] < -SP_FRAME_WORK_REACH_MAX) {
                return SP_E_RANGE;
            }
        }
        if (!angles_ok(work->rpy)) {
            return SP_E_RANGE;
        }
    }
    if (tool != NULL) {
        f->tool = *tool;
        f->tool_turned = (uint8_t)(all_zero(tool->rpy) ? 0u : 1u);
        if (f->tool_turned) {
            spi_orientation_sc(tool->rpy, &f->tool_rot, sc);
        }
    }
    if (work != NULL) {
        f->work = *work;
        f->work_turned = (uint8_t)(all_zero(work->rpy) ? 0u : 1u);
        if (f->work_turned) {
            spi_orientation_sc(work->rpy, &f->work_rot, sc);
        }
    }
    f->identity = (uint8_t)(all_zero(f->tool.pos) && all_zero(f->work.pos) && !f->tool_turned && !f->work_turned);
    return SP_OK;
}

/* ---- poses -------------------------------------------------------------------------------- */

static void copy_pose(const sp_pose_t *in, sp_pose_t *out)
{
    *out = *in;
}

/* out = in for three values, written out: -Os makes a loop of three a
 * call of memmove, which costs more than the copy. */
static void copy3(int32_t out[3], const int32_t in[3])
{
    out[0] = in[0];
    out[1] = in[1];
    out[2] = in[2];
}

/* T_P of a tool pose whose T_X is given: T_P = T_T^T T_X T_W; angles into
 * rpy (copied from x when no frame is turned). */
static void platform_rot(const sp_frames_t *f, const sp_rot_t *tx, const sp_q24_t x_rpy[3], sp_rot_t *tp,
                         sp_q24_t rpy[3])
{
    sp_rot_t m;
    unsigned k;
    if (!f->tool_turned && !f->work_turned) {
        *tp = *tx;
        for (k = 0u; k < 3u; ++k) {
            rpy[k] = x_rpy[k];
        }
        return;
    }
    if (f->tool_turned) {
        rot_mul(&f->tool_rot, 1, tx, 0, &m);
    } else {
        m = *tx;
    }
    if (f->work_turned) {
        rot_mul(&m, 0, &f->work_rot, 0, tp);
    } else {
        *tp = m;
    }
    angles_of(tp, rpy);
}

/* p = w + R_W x - R_P t, Q24, saturating. */
static sp_flags_t platform_pos(const sp_frames_t *f, const sp_rot_t *tp, const sp_q24_t x[3], sp_q24_t p[3])
{
    int64_t acc[3] = {0, 0, 0};
    sp_flags_t flags = 0u;
    unsigned k;
    if (f->work_turned) {
        acc_out(&f->work_rot, x, 1, acc);
    } else {
        for (k = 0u; k < 3u; ++k) {
            acc[k] = (int64_t)x[k] * SP_Q30_ONE;
        }
    }
    acc_out(tp, f->tool.pos, -1, acc);
    for (k = 0u; k < 3u; ++k) {
        acc[k] += (int64_t)f->work.pos[k] * SP_Q30_ONE;
        p[k] = spi_narrow_away(acc[k], 30u, &flags);
    }
    return flags;
}

sp_status_t sp_frames_to_platform(const sp_frames_t *f, const sp_pose_t *tool_pose, sp_pose_t *platform, sp_rot_t *rot)
{
    sp_rot_t tx, tp;
    sp_q30_t sc[6];
    sp_q24_t pos[3];
    sp_flags_t flags;
    if (f == NULL || tool_pose == NULL || platform == NULL) {
        return SP_E_ARG;
    }
    if (f->identity && rot == NULL) {
        copy_pose(tool_pose, platform);
        return SP_OK;
    }
    spi_orientation_sc(tool_pose->rpy, &tx, sc);
    platform_rot(f, &tx, tool_pose->rpy, &tp, platform->rpy);
    flags = platform_pos(f, &tp, tool_pose->pos, pos);
    platform->pos[0] = pos[0];
    platform->pos[1] = pos[1];
    platform->pos[2] = pos[2];
    if (rot != NULL) {
        *rot = tp;
    }
    return sp_flags_status(flags);
}

sp_status_t sp_frames_from_platform(const sp_frames_t *f, const sp_pose_t *platform, sp_pose_t *tool_pose)
{
    sp_rot_t tp, m, tx;
    sp_q30_t sc[6];
    int64_t acc[3] = {0, 0, 0};
    int32_t d[3];
    sp_flags_t flags = 0u;
    unsigned k;
    if (f == NULL || tool_pose == NULL || platform == NULL) {
        return SP_E_ARG;
    }
    if (f->identity) {
        copy_pose(platform, tool_pose);
        return SP_OK;
    }
    spi_orientation_sc(platform->rpy, &tp, sc);
    /* d = p + R_P t - w (Q24), then x = R_W^T d */
    acc_out(&tp, f->tool.pos, 1, acc);
    for (k = 0u; k < 3u; ++k) {
        acc[k] += ((int64_t)platform->pos[k] - f->work.pos[k]) * SP_Q30_ONE;
        d[k] = spi_narrow_away(acc[k], 30u, &flags);
    }
    if (f->work_turned) {
        int64_t x[3] = {0, 0, 0};
        acc_in(&f->work_rot, d, x);
        for (k = 0u; k < 3u; ++k) {
            d[k] = spi_narrow_away(x[k], 30u, &flags);
        }
    }
    /* T_X = T_T T_P T_W^T */
    if (f->tool_turned || f->work_turned) {
        if (f->tool_turned) {
            rot_mul(&f->tool_rot, 0, &tp, 0, &m);
        } else {
            m = tp;
        }
        if (f->work_turned) {
            rot_mul(&m, 0, &f->work_rot, 1, &tx);
        } else {
            tx = m;
        }
        angles_of(&tx, tool_pose->rpy);
    } else {
        for (k = 0u; k < 3u; ++k) {
            tool_pose->rpy[k] = platform->rpy[k];
        }
    }
    for (k = 0u; k < 3u; ++k) {
        tool_pose->pos[k] = d[k];
    }
    return sp_flags_status(flags);
}

/* ---- motions ------------------------------------------------------------------------------ */

/* Q24 x Q30 -> Q24 (int64 in, rounded). */
static int64_t m30(int64_t v, int32_t s)
{
    return spi_round_away64(v * s, 30u);
}

/* Euler rates (rad/s, Q24, int64) from body rates w (motion-frame axes)
 * with the sines sc of roll, pitch: pitch' = cr wy - sr wz, yaw' = (sr wy
 * + cr wz) / cp, roll' = wx + sp yaw'. */
static void euler_of_body(const sp_q30_t sc[6], const int64_t w[3], int64_t r[3], sp_flags_t *flags)
{
    int64_t q = m30(w[1], sc[0]) + m30(w[2], sc[1]);
    r[1] = m30(w[1], sc[1]) - m30(w[2], sc[0]);
    r[2] = sp_div64(q, sc[3], 30u, flags);
    r[0] = w[0] + m30(r[2], sc[2]);
}

/* The platform's Euler rates and accelerations from its body rates w and
 * accelerations dw (motion-frame axes, Q24) at the sines sc:
 * rpy'' = E^-1 (dw - E' rpy'). */
static void platform_euler(const sp_q30_t sc[6], const int64_t w[3], const int64_t dw[3], sp_motion_t *out,
                           sp_flags_t *flags)
{
    int64_t r[3], b[3], a[3];
    int64_t dr, dp, dy, dpdr, dydr, dydp;
    unsigned k;
    sp_q30_t sr = sc[0], cr = sc[1], sp = sc[2], cp = sc[3];
    euler_of_body(sc, w, r, flags);
    dr = r[0];
    dp = r[1];
    dy = r[2];
    dpdr = spi_round_away64(dp * dr, 24u);
    dydr = spi_round_away64(dy * dr, 24u);
    dydp = spi_round_away64(dy * dp, 24u);
    b[0] = dw[0] + m30(dydp, cp);
    b[1] = dw[1] + m30(dpdr, sr) - m30(dydr, spi_mul30_away(cp, cr)) + m30(dydp, spi_mul30_away(sr, sp));
    b[2] = dw[2] + m30(dpdr, cr) + m30(dydr, spi_mul30_away(sr, cp)) + m30(dydp, spi_mul30_away(cr, sp));
    euler_of_body(sc, b, a, flags);
    for (k = 0u; k < 3u; ++k) {
        out->rpy_rate[k] = spi_sat(r[k], flags);
        out->rpy_acc[k] = spi_sat(a[k], flags);
    }
}

/* a x b for int32 vectors, Q24 x Q24 -> Q24, saturated to int32: each
 * product 32 x 32 bits, their difference below 2^63. */
static void cross32(const int32_t a[3], const int32_t b[3], int32_t out[3], sp_flags_t *flags)
{
    out[0] = spi_sat(spi_round_away((int64_t)a[1] * b[2] - (int64_t)a[2] * b[1], 24u), flags);
    out[1] = spi_sat(spi_round_away((int64_t)a[2] * b[0] - (int64_t)a[0] * b[2], 24u), flags);
    out[2] = spi_sat(spi_round_away((int64_t)a[0] * b[1] - (int64_t)a[1] * b[0], 24u), flags);
}

/* v_P = R_W v_X - R_P (w x t), a_P = R_W a_X - R_P (dw x t + w x (w x t)),
 * w, dw the body rates (motion-frame axes); `turning` 0: w = dw = 0. */
static void platform_linear(const sp_frames_t *f, const sp_rot_t *tp, const sp_motion_t *x, const int32_t w[3],
                            const int32_t dw[3], int turning, sp_motion_t *out, sp_flags_t *flags)
{
    int64_t v[3] = {0, 0, 0}, a[3] = {0, 0, 0};
    unsigned k;
    if (turning) {
        int32_t wt[3], dwt[3], wwt[3];
        cross32(w, f->tool.pos, wt, flags);
        cross32(dw, f->tool.pos, dwt, flags);
        cross32(w, wt, wwt, flags);
        for (k = 0u; k < 3u; ++k) {
            dwt[k] = spi_add(dwt[k], wwt[k], flags);
        }
        acc_out(tp, wt, -1, v);
        acc_out(tp, dwt, -1, a);
    }
    if (f->work_turned) {
        acc_out(&f->work_rot, x->vel, 1, v);
        acc_out(&f->work_rot, x->acc, 1, a);
        for (k = 0u; k < 3u; ++k) {
            out->vel[k] = spi_narrow_away(v[k], 30u, flags);
            out->acc[k] = spi_narrow_away(a[k], 30u, flags);
        }
    } else if (turning) {
        for (k = 0u; k < 3u; ++k) {
            out->vel[k] = spi_add(x->vel[k], spi_narrow_away(v[k], 30u, flags), flags);
            out->acc[k] = spi_add(x->acc[k], spi_narrow_away(a[k], 30u, flags), flags);
        }
    } else {
        copy3(out->vel, x->vel);
        copy3(out->acc, x->acc);
    }
}

/* The platform's body rates (motion-frame axes, Q24) from the tool's:
 * w_P = R_T w_X (T's axes to the motion frame's). */
static void body_to_platform(const sp_frames_t *f, sp_q24_t v[3], sp_flags_t *flags)
{
    unsigned k;
    if (f->tool_turned) {
        int64_t acc[3] = {0, 0, 0};
        acc_out(&f->tool_rot, v, 1, acc);
        for (k = 0u; k < 3u; ++k) {
            v[k] = spi_narrow_away(acc[k], 30u, flags);
        }
    }
}

/* Is a tool motion turning (any Euler rate or acceleration not 0)? */
static int turning_of(const sp_motion_t *x)
{
    return (x->rpy_rate[0] | x->rpy_rate[1] | x->rpy_rate[2] | x->rpy_acc[0] | x->rpy_acc[1] | x->rpy_acc[2]) != 0;
}

/* The sine and cosine of angle a into sc[j], sc[j + 1]. */
static void sincos_into(sp_q24_t a, sp_q30_t *sc, unsigned j)
{
    sp_sincos_q24(a, &sc[j], &sc[j + 1u]);
}

/* The angles' rates with turned frames: through the body rates, at the
 * platform angles' sines scp. */
static sp_status_t turned_rates(const sp_motion_t *x, const sp_q30_t scp[6], const sp_q24_t w[3], const sp_q24_t dw[3],
                                sp_motion_t *out, sp_flags_t *flags)
{
    int64_t w64[3], dw64[3];
    unsigned k;
    if (scp[3] < SP_Q30_MILLI(10) && scp[3] > -SP_Q30_MILLI(10)) {
        return SP_E_SINGULAR;
    }
    if (turning_of(x)) {
        for (k = 0u; k < 3u; ++k) {
            w64[k] = w[k];
            dw64[k] = dw[k];
        }
        platform_euler(scp, w64, dw64, out, flags);
    } else {
        for (k = 0u; k < 3u; ++k) {
            out->rpy_rate[k] = 0;
            out->rpy_acc[k] = 0;
        }
    }
    return SP_OK;
}

/* What a tool motion's transform needs of its orientation: sc the sines
 * of the tool angles, tp the paper's T of the platform, rpy the
 * platform's angles and scp their sines (turned frames only). */
typedef struct {
    const sp_q30_t *sc;
    const sp_rot_t *tp;
    const sp_q24_t *rpy;
    const sp_q30_t *scp;
} motion_orient_t;

/* The body rates w, dw of a tool motion's Euler rates (st: how
 * sp_body_rates_sc made them) into the IK's keep, for the inverse
 * dynamics. */
static void keep_body_rates(sp_orient_keep_t *keep, const sp_motion_t *m, const sp_q24_t w[3], const sp_q24_t dw[3],
                            sp_status_t st)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        keep->rates_of[k] = m->rpy_rate[k];
        keep->rates_of[k + 3u] = m->rpy_acc[k];
        keep->body[k] = w[k];
        keep->body[k + 3u] = dw[k];
    }
    keep->rates_valid = (st == SP_OK) ? 1u : 0u;
}

/* sp_frames_motion_to_platform past its orientation (f not identity);
 * body: the IK's keep that shares the orientation (no frame turned), where
 * the body rates are kept, else NULL. */
static sp_status_t motion_core(const sp_frames_t *f, const motion_orient_t *o, const sp_motion_t *tool_motion,
                               sp_motion_t *platform, sp_orient_keep_t *body)
{
    sp_q24_t w[3] = {0, 0, 0}, dw[3] = {0, 0, 0};
    sp_flags_t flags = 0u;
    int turning = turning_of(tool_motion);
    copy3(platform->pose.rpy, o->rpy);
    flags |= platform_pos(f, o->tp, tool_motion->pose.pos, platform->pose.pos);
    if (turning) {
        sp_status_t st = sp_body_rates_sc(o->sc, tool_motion->rpy_rate, tool_motion->rpy_acc, w, dw);
        flags |= (st == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
        if (body != NULL) {
            /* the platform's Euler rates are the tool's and o->sc its
             * sines: the inverse dynamics' body rates, made once */
            keep_body_rates(body, tool_motion, w, dw, st);
        }
        body_to_platform(f, w, &flags);
        body_to_platform(f, dw, &flags);
    }
    if (f->tool_turned || f->work_turned) {
        if (turned_rates(tool_motion, o->scp, w, dw, platform, &flags) != SP_OK) {
            return SP_E_SINGULAR;
        }
    } else {
        copy3(platform->rpy_rate, tool_motion->rpy_rate);
        copy3(platform->rpy_acc, tool_motion->rpy_acc);
    }
    platform_linear(f, o->tp, tool_motion, w, dw, turning && (f->tool.pos[0] | f->tool.pos[1] | f->tool.pos[2]) != 0,
                    platform, &flags);
    return sp_flags_status(flags);
}

sp_status_t sp_frames_motion_to_platform(const sp_frames_t *f, const sp_motion_t *tool_motion, sp_motion_t *platform)
{
    sp_rot_t tx, tp;
    sp_q30_t sc[6], scp[6];
    sp_q24_t rpy[3];
    motion_orient_t o;
    unsigned k;
    if (f == NULL || tool_motion == NULL || platform == NULL || tool_motion == platform) {
        return SP_E_ARG;
    }
    if (f->identity) {
        *platform = *tool_motion;
        return SP_OK;
    }
    spi_orientation_sc(tool_motion->pose.rpy, &tx, sc);
    platform_rot(f, &tx, tool_motion->pose.rpy, &tp, rpy);
    if (f->tool_turned || f->work_turned) {
        for (k = 0u; k < 3u; ++k) {
            sincos_into(rpy[k], scp, k + k);
        }
    }
    o.sc = sc;
    o.tp = &tp;
    o.rpy = rpy;
    o.scp = scp;
    return motion_core(f, &o, tool_motion, platform, NULL);
}

/* keep brought to the tool angles rpy: each angle that changed gets its
 * sine, and any change remakes T_X, T_P, the platform's angles and (turned
 * frames) their sines; nothing when no angle changed. */
static void keep_update(const sp_frames_t *f, const sp_q24_t rpy[3], sp_frames_keep_t *keep)
{
    sp_rot_t tx;
    unsigned k;
    int changed = !keep->valid;
    for (k = 0u; k < 3u; ++k) {
        if (!keep->valid || rpy[k] != keep->tool_rpy[k]) {
            sincos_into(rpy[k], keep->sc, k + k);
            keep->tool_rpy[k] = rpy[k];
            changed = 1;
        }
    }
    if (!changed) {
        return;
    }
    spi_rot_from_sincos(keep->sc, &tx);
    platform_rot(f, &tx, rpy, &keep->tp, keep->rpy);
    if (f->tool_turned || f->work_turned) {
        for (k = 0u; k < 3u; ++k) {
            if (!keep->valid || keep->rpy[k] != keep->prpy_of[k]) {
                sincos_into(keep->rpy[k], keep->scp, k + k);
                keep->prpy_of[k] = keep->rpy[k];
            }
        }
    }
    keep->valid = 1u;
}

sp_status_t sp_frames_motion_to_platform_kept(const sp_frames_t *f, sp_frames_keep_t *keep,
                                              const sp_motion_t *tool_motion, sp_motion_t *platform)
{
    motion_orient_t o;
    if (keep == NULL) {
        return sp_frames_motion_to_platform(f, tool_motion, platform);
    }
    if (f == NULL || tool_motion == NULL || platform == NULL || tool_motion == platform) {
        return SP_E_ARG;
    }
    if (f->identity) {
        *platform = *tool_motion;
        return SP_OK;
    }
    keep_update(f, tool_motion->pose.rpy, keep);
    o.sc = keep->sc;
    o.tp = &keep->tp;
    o.rpy = keep->rpy;
    o.scp = keep->scp;
    return motion_core(f, &o, tool_motion, platform, NULL);
}

sp_status_t sp_frames_motion_to_platform_shared(const sp_frames_t *f, sp_frames_keep_t *keep, sp_orient_keep_t *orient,
                                                const sp_motion_t *tool_motion, sp_motion_t *platform)
{
    motion_orient_t o;
    int flat;
    if (orient == NULL || f == NULL || f->tool_turned || f->work_turned) {
        return sp_frames_motion_to_platform_kept(f, keep, tool_motion, platform);
    }
    if (tool_motion == NULL || platform == NULL || tool_motion == platform) {
        return SP_E_ARG;
    }
    if (f->identity) {
        *platform = *tool_motion;
        return SP_OK;
    }
    /* no frame turned: the platform's angles are the tool's, and T_P = T_X
     * (platform_rot) is the IK's T of them */
    if (spi_orient_update(orient, tool_motion->pose.rpy, &flat)) {
        orient->fresh = 1u;
    }
    o.sc = orient->sc;
    o.tp = &orient->rot;
    o.rpy = tool_motion->pose.rpy;
    o.scp = orient->sc; /* not read: no frame turned */
    return motion_core(f, &o, tool_motion, platform, orient);
}

sp_status_t sp_frames_to_platform_kept(const sp_frames_t *f, sp_frames_keep_t *keep, const sp_pose_t *tool_pose,
                                       sp_pose_t *platform)
{
    sp_q24_t pos[3];
    sp_flags_t flags;
    unsigned k;
    if (keep == NULL) {
        return sp_frames_to_platform(f, tool_pose, platform, NULL);
    }
    if (f == NULL || tool_pose == NULL || platform == NULL) {
        return SP_E_ARG;
    }
    if (f->identity) {
        copy_pose(tool_pose, platform);
        return SP_OK;
    }
    keep_update(f, tool_pose->rpy, keep);
    flags = platform_pos(f, &keep->tp, tool_pose->pos, pos);
    for (k = 0u; k < 3u; ++k) {
        platform->pos[k] = pos[k];
        platform->rpy[k] = keep->rpy[k];
    }
    return sp_flags_status(flags);
}

/* ---- wrenches ----------------------------------------------------------------------------- */

/* r = R_P t (base coordinates, Q24): |r| <= |t| (1 + 2^-27) < 2^27, an int32. */
static void lever(const sp_frames_t *f, const sp_rot_t *rot, int32_t r[3])
{
    int64_t acc[3] = {0, 0, 0};
    unsigned k;
    acc_out(rot, f->tool.pos, 1, acc);
    for (k = 0u; k < 3u; ++k) {
        r[k] = (int32_t)spi_round_away64(acc[k], 30u);
    }
}

/* m + sign r x F (Q8, int64): r Q24 (an int32), F Q8 (|F| < 2^33): each
 * product below 2^60. */
static void moment_shift(const int32_t r[3], const int64_t fo[3], const int64_t m[3], int sign, int64_t out[3])
{
    int64_t c0 = spi_round_away64((int64_t)r[1] * fo[2] - (int64_t)r[2] * fo[1], 24u);
    int64_t c1 = spi_round_away64((int64_t)r[2] * fo[0] - (int64_t)r[0] * fo[2], 24u);
    int64_t c2 = spi_round_away64((int64_t)r[0] * fo[1] - (int64_t)r[1] * fo[0], 24u);
    out[0] = m[0] + sign * c0;
    out[1] = m[1] + sign * c1;
    out[2] = m[2] + sign * c2;
}

/* v (Q8, int64) turned by W: in (outer to W's axes) or out. */
static void turn_w(const sp_frames_t *f, int64_t v[3], int to_w, sp_flags_t *flags)
{
    int32_t n[3];
    int64_t acc[3] = {0, 0, 0};
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        n[k] = spi_sat(v[k], flags);
    }
    if (to_w) {
        acc_in(&f->work_rot, n, acc);
    } else {
        acc_out(&f->work_rot, n, 1, acc);
    }
    for (k = 0u; k < 3u; ++k) {
        v[k] = spi_round_away64(acc[k], 30u);
    }
}

/* The wrench at the tool point, W's axes, of one about o' (f not identity):
 * wrench_move(.., 1) in 32-bit operands (F an int32, |r| < 2^27: each
 * product below 2^58), the same values. */
static sp_status_t wrench_to(const sp_frames_t *f, const int32_t r[3], const int32_t in[6], int32_t out[6])
{
    sp_flags_t flags = 0u;
    int32_t n[3];
    int64_t a[3] = {0, 0, 0};
    int64_t b[3] = {0, 0, 0};
    unsigned k;
    n[0] = spi_sat((int64_t)in[3] - spi_round_away((int64_t)r[1] * in[2] - (int64_t)r[2] * in[1], 24u), &flags);
    n[1] = spi_sat((int64_t)in[4] - spi_round_away((int64_t)r[2] * in[0] - (int64_t)r[0] * in[2], 24u), &flags);
    n[2] = spi_sat((int64_t)in[5] - spi_round_away((int64_t)r[0] * in[1] - (int64_t)r[1] * in[0], 24u), &flags);
    if (!f->work_turned) {
        copy3(out, in);
        copy3(&out[3], n);
        return sp_flags_status(flags);
    }
    acc_in(&f->work_rot, in, a);
    acc_in(&f->work_rot, n, b);
    for (k = 0u; k < 3u; ++k) {
        out[k] = spi_narrow_away(a[k], 30u, &flags);
        out[3u + k] = spi_narrow_away(b[k], 30u, &flags);
    }
    return sp_flags_status(flags);
}

/* The wrench moved with the lever r (f not identity). */
static sp_status_t wrench_move(const sp_frames_t *f, const int32_t r[3], const int32_t in[6], int32_t out[6],
                               int to_tool)
{
    int64_t fo[3], m[3], mo[3];
    sp_flags_t flags = 0u;
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        fo[k] = in[k];
        m[k] = in[3u + k];
    }
    if (to_tool) {
        moment_shift(r, fo, m, -1, mo);
        if (f->work_turned) {
            turn_w(f, fo, 1, &flags);
            turn_w(f, mo, 1, &flags);
        }
    } else {
        if (f->work_turned) {
            turn_w(f, fo, 0, &flags);
            turn_w(f, m, 0, &flags);
        }
        moment_shift(r, fo, m, 1, mo);
    }
    for (k = 0u; k < 3u; ++k) {
        out[k] = spi_sat(fo[k], &flags);
        out[3u + k] = spi_sat(mo[k], &flags);
    }
    return sp_flags_status(flags);
}

static int copy_wrench(const sp_frames_t *f, const int32_t in[6], int32_t out[6])
{
    unsigned k;
    if (!f->identity) {
        return 0;
    }
    for (k = 0u; k < 6u; ++k) {
        out[k] = in[k];
    }
    return 1;
}

sp_status_t sp_frames_lever(const sp_frames_t *f, const sp_rot_t *rot, sp_q24_t r[3])
{
    if (f == NULL || rot == NULL || r == NULL) {
        return SP_E_ARG;
    }
    lever(f, rot, r);
    return SP_OK;
}

sp_status_t sp_frames_wrench_to_tool_at(const sp_frames_t *f, const sp_q24_t r[3], const int32_t wrench[6],
                                        int32_t tool_wrench[6])
{
    if (f == NULL || r == NULL || wrench == NULL || tool_wrench == NULL) {
        return SP_E_ARG;
    }
    return copy_wrench(f, wrench, tool_wrench) ? SP_OK : wrench_to(f, r, wrench, tool_wrench);
}

sp_status_t sp_frames_wrench_to_tool(const sp_frames_t *f, const sp_rot_t *rot, const int32_t wrench[6],
                                     int32_t tool_wrench[6])
{
    int32_t r[3];
    if (f == NULL || rot == NULL || wrench == NULL || tool_wrench == NULL) {
        return SP_E_ARG;
    }
    if (copy_wrench(f, wrench, tool_wrench)) {
        return SP_OK;
    }
    lever(f, rot, r);
    return wrench_to(f, r, wrench, tool_wrench);
}

sp_status_t sp_frames_wrench_from_tool(const sp_frames_t *f, const sp_rot_t *rot, const int32_t tool_wrench[6],
                                       int32_t wrench[6])
{
    int32_t r[3];
    if (f == NULL || rot == NULL || wrench == NULL || tool_wrench == NULL) {
        return SP_E_ARG;
    }
    if (copy_wrench(f, tool_wrench, wrench)) {
        return SP_OK;
    }
    lever(f, rot, r);
    return wrench_move(f, r, tool_wrench, wrench, 0);
}

/* ---- checksum ----------------------------------------------------------------------------- */

static uint32_t crc_word(uint32_t crc_in, int32_t v)
{
    uint32_t crc = crc_in;
    uint32_t u = (uint32_t)v;
    unsigned b, i;
    for (b = 0u; b < 4u; ++b) {
        crc ^= (u >> (8u * b)) & 0xFFu;
        for (i = 0u; i < 8u; ++i) {
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
        }
    }
    return crc;
}

uint32_t sp_frames_checksum(const sp_frames_t *f)
{
    uint32_t crc = 0xFFFFFFFFu;
    unsigned k;
    if (f == NULL) {
        return 0u;
    }
    for (k = 0u; k < 3u; ++k) {
        crc = crc_word(crc, f->tool.pos[k]);
    }
    for (k = 0u; k < 3u; ++k) {
        crc = crc_word(crc, f->tool.rpy[k]);
    }
    for (k = 0u; k < 3u; ++k) {
        crc = crc_word(crc, f->work.pos[k]);
    }
    for (k = 0u; k < 3u; ++k) {
        crc = crc_word(crc, f->work.rpy[k]);
    }
    return crc ^ 0xFFFFFFFFu;
}
