/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/motion/stream.h"

#include "math/fixed_inline.h"

/* Settled: within 1 um (1 urad) and 1 um/s (1 urad/s), Q24. */
#define STREAM_SETTLED INT32_C(16)
/* stream_axis_near's common case: a tick below 1 s (dt < 2^24, Q24), a
 * state position below 64 m (2^54, Q48), a velocity limit below 64 m/s
 * (2^30, Q24) */
#define STREAM_DT_NEAR (UINT32_C(1) << 24)
#define STREAM_X_NEAR (INT64_C(1) << 54)
#define STREAM_V_NEAR (UINT32_C(1) << 30)
/* The tick whose dt (Q24 s) reaches 2^31: 128 s */
#define STREAM_TICK_MAX_US UINT32_C(128000000)

sp_status_t sp_stream_gains(sp_stream_gains_t *g, uint32_t tick_us, sp_q24_t omega)
{
    if (g == NULL) {
        return SP_E_ARG;
    }
    g->flags = 0u;
    if (tick_us >= STREAM_TICK_MAX_US) { /* dt would leave int32 */
        g->dt = INT32_MAX;
        g->flags |= SP_FLAG_OVERFLOW;
    } else { /* tick_us 2^24 < 2^31 10^6: the quotient fits int32 */
        g->dt = (int32_t)spi_udiv64_32((uint64_t)tick_us << 24, 1000000u, NULL);
    }
    g->w2 = spi_mul_away(omega, omega, 24u, &g->flags);
    g->two_w = spi_add(omega, omega, &g->flags);
    return SP_OK;
}

void sp_stream_start(sp_stream_t *s, const sp_motion_t *from)
{
    unsigned i;
    s->target = from->pose;
    s->stopping = 0u;
    s->anchor_valid = 0u;
    for (i = 0u; i < 6u; ++i) {
        s->x[i] = (int64_t)sp_pose_axis(&from->pose, (sp_axis_t)i) * (INT64_C(1) << 24);
        s->v[i] = 0;
        s->vq[i] = 0;
    }
}

void sp_stream_stop(sp_stream_t *s, const sp_pose_t *home)
{
    s->target = *home;
    s->stopping = 1u;
}

/* Early out: a streamed target usually differs from the last in x. */
static int same_pose(const sp_pose_t *a, const sp_pose_t *b)
{
    unsigned i;
    for (i = 0u; i < 3u; ++i) {
        if (a->pos[i] != b->pos[i] || a->rpy[i] != b->rpy[i]) {
            return 0;
        }
    }
    return 1;
}

/* How far `pose` is from `base`: the sums over the axes of |pose - base|,
 * positions (m) and angles (rad), Q24, each below 3 2^32. */
static void pose_dist(const sp_pose_t *base, const sp_pose_t *pose, uint64_t d[2])
{
    unsigned k;
    d[0] = 0u;
    d[1] = 0u;
    for (k = 0u; k < 3u; ++k) {
        d[0] += spi_dist32(pose->pos[k], base->pos[k]);
        d[1] += spi_dist32(pose->rpy[k], base->rpy[k]);
    }
}

/* sp_limits_reachable_near's bound, split in two so that a base's part is
 * computed once: how far (m, Q24) a leg can move over the distances d
 * (pose_dist), or -1 when the bound is not conclusive (the same rule,
 * term for term; a conclusive bound is below 2^31, and so are then both
 * distances). */
static int32_t near_delta(const sp_limits_t *lim, const uint64_t d[2])
{
    uint64_t delta;
    if (d[1] >= (UINT64_C(1) << 31) || lim->joint_reach == UINT32_MAX) {
        return -1;
    }
    delta = d[0] + (((uint64_t)lim->joint_reach * d[1]) >> 24) + 5u;
    return (delta >= (UINT64_C(1) << 31)) ? -1 : (int32_t)delta;
}

/* A room (Q24) saturated to int32: beyond, it proves every bound that can
 * be tested against it (all below 2^31), or none. */
static int32_t room32(int64_t room)
{
    return (room > INT32_MAX) ? INT32_MAX : (room < INT32_MIN) ? INT32_MIN : (int32_t)room;
}

/* ... and the base's part: the least room (m, Q24) of its legs to the
 * stroke limits, min over the legs of l - length_min and length_max - l
 * (negative when a leg is outside). sp_limits_reachable_near(base, length,
 * pose) is near_delta(pose_dist(base, pose)) in [0, legs_room(length)]. */
static int32_t legs_room(const sp_limits_t *lim, const sp_q24_t length[SP_LEGS])
{
    int64_t room = INT64_MAX;
    unsigned k;
    for (k = 0u; k < SP_LEGS; ++k) {
        int64_t lo = (int64_t)length[k] - lim->length_min;
        int64_t hi = (int64_t)lim->length_max - length[k];
        room = (lo < room) ? lo : room;
        room = (hi < room) ? hi : room;
    }
    return room32(room);
}

/* The least room (Q24) of a pose to the workspace box's faces, positions
 * (room[0], m) and angles (room[1], rad) apart, negative when it is
 * outside: a pose whose pose_dist from it is within both is inside the
 * box (no axis moves farther than the sum over its kind). */
static void box_room(const sp_limits_t *lim, const sp_pose_t *pose, int32_t room[2])
{
    int64_t r[2] = {INT64_MAX, INT64_MAX};
    unsigned a;
    for (a = 0u; a < 6u; ++a) {
        int64_t at = sp_pose_axis(pose, (sp_axis_t)a);
        int64_t lo = at - lim->ws_lo[a];
        int64_t hi = lim->ws_hi[a] - at;
        int64_t *k = &r[a / 3u];
        *k = (lo < *k) ? lo : *k;
        *k = (hi < *k) ? hi : *k;
    }
    room[0] = room32(r[0]);
    room[1] = room32(r[1]);
}

SPI_NOINLINE static void set_anchor(sp_stream_t *s, const sp_limits_t *lim, const sp_pose_t *pose, int32_t room)
{
    s->anchor = *pose;
    s->anchor_room = room;
    box_room(lim, pose, s->anchor_box);
    s->anchor_valid = 1u;
}

/* Is a streamed target reachable (sp_stream_offer's rule)? The anchor's
 * rooms are kept, to its legs' stroke limits and to the workspace box, so
 * that a target near it costs the distance alone (no leg loop, no box
 * test); the last reference (its legs' room computed here) becomes the
 * anchor when it proves a target. Every test is sufficient
 * (sp_limits_reachable_near; the box room), so their order does not change
 * the answer. */
static int target_reachable(sp_stream_t *s, const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *t,
                            const sp_pose_t *ref_pose, const sp_q24_t ref_length[SP_LEGS])
{
    sp_q24_t length[SP_LEGS];
    uint64_t d[2];
    int32_t delta;
    int anchor_near = 0;
    if (same_pose(t, &s->target)) {
        return 1; /* the target in force (checked when it was taken, or the reference STREAM began at) */
    }
    if (s->anchor_valid) {
        pose_dist(&s->anchor, t, d);
        delta = near_delta(lim, d);
        anchor_near = delta >= 0 && delta <= s->anchor_room;
        if (anchor_near && (int32_t)d[0] <= s->anchor_box[0] && (int32_t)d[1] <= s->anchor_box[1]) {
            return 1; /* near the anchor, inside the box */
        }
    }
    if (!sp_limits_in_workspace(lim, t)) {
        return 0;
    }
    if (anchor_near) {
        return 1;
    }
    if (ref_length != NULL) {
        int32_t room = legs_room(lim, ref_length);
        pose_dist(ref_pose, t, d);
        delta = near_delta(lim, d);
        if (delta >= 0 && delta <= room) {
            set_anchor(s, lim, ref_pose, room);
            return 1;
        }
    }
    if (!sp_limits_legs_reachable(lim, platform, t, length)) {
        return 0;
    }
    set_anchor(s, lim, t, legs_room(lim, length));
    return 1;
}

int sp_stream_offer(sp_stream_t *s, const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *target,
                    const sp_pose_t *ref_pose, const sp_q24_t ref_length[SP_LEGS])
{
    if (s->stopping || !target_reachable(s, lim, platform, target, ref_pose, ref_length)) {
        return 0;
    }
    s->target = *target;
    return 1;
}

/* One axis of the filter, the general way: target (Q24), state x48, v48
 * (Q48) and vq (round(v48 / 2^24)), outputs x, v, acc (Q24), for any tick
 * and state; every sum saturates. |v48| <= vmax < 2^55 (clamped below,
 * and 0 at the start), so its Q24 value fits int32 and v48 + acmd dt
 * (< 2^56) cannot overflow. Resting on its target (every term 0), the
 * outputs are written and the state kept. */
SPI_NOINLINE static void stream_axis_sat(sp_q24_t target, int64_t *x48p, int64_t *v48p, int32_t *vqp, int32_t vel_max,
                                         int32_t amax, const sp_stream_gains_t *g, sp_q24_t *x, sp_q24_t *v,
                                         sp_q24_t *acc, sp_flags_t *flags)
{
    int64_t vmax = (int64_t)vel_max * (INT64_C(1) << 24);
    int64_t t48 = (int64_t)target * (INT64_C(1) << 24);
    int64_t x48 = *x48p;
    int64_t v48 = *v48p;
    int32_t err;
    int32_t acmd;
    if (x48 == t48 && v48 == 0) {
        *acc = 0;
        *v = 0;
        *x = target;
        return;
    }
    err = spi_narrow_away(spi_add64(t48, -x48, flags), 24u, flags);
    acmd = spi_sub(spi_mul_away(g->w2, err, 24u, flags), spi_mul_away(g->two_w, *vqp, 24u, flags), flags);
    acmd = acmd > amax ? amax : (acmd < -amax ? -amax : acmd);
    v48 += (int64_t)acmd * g->dt; /* Q48 */
    v48 = v48 > vmax ? vmax : (v48 < -vmax ? -vmax : v48);
    x48 = spi_add64(x48, spi_mul64_up(v48, g->dt, 24u, flags), flags);
    *v48p = v48;
    *x48p = x48;
    *vqp = (sp_q24_t)spi_round_away(v48, 24u);
    *acc = acmd;
    *v = *vqp;
    *x = spi_narrow_away(x48, 24u, flags);
}

/* round(a b / 2^24), ties away from zero, for |a b| < 2^62: the rounding's
 * bias (2^23, less 1 when the product is negative, i.e. when a and b have
 * opposite signs; a product of 0 rounds to 0 with either) added by the
 * multiply itself. */
SPI_INLINE int64_t stream_mul24(int32_t a, int32_t b)
{
    int32_t neg = (int32_t)((uint32_t)(a ^ b) >> 31);
    return ((int64_t)a * b + (INT32_C(0x800000) - neg)) >> 24;
}

/* floor(v / 2^24) of a Q48 value v with |v| < 2^55 (the Q24 part: it fits
 * int32), from v's two words. */
SPI_INLINE int32_t stream_floor24(int64_t v)
{
    return (int32_t)(((uint32_t)((uint64_t)v >> 32) << 8) | ((uint32_t)v >> 24));
}

/* round(v / 2^24), ties away from zero, of that v from i = floor(v / 2^24)
 * and its fraction f = v mod 2^24: spi_round_away's bias (2^23, less 1
 * when v < 0, i.e. i < 0) added to the fraction alone, whose carry is the
 * rounding. */
SPI_INLINE int32_t stream_round24(int32_t i, uint32_t f)
{
    return i + (int32_t)((f + 0x800000u - ((uint32_t)i >> 31)) >> 24);
}

/* The same axis in the common case, with the same values and no sum that
 * can saturate; returns 0 (nothing written) outside it. The common case:
 * a tick below 1 s (checked by the caller, 0 <= dt < 2^24), |x48| < 2^54
 * (64 m), -2^22 <= target - floor(x48 / 2^24) < 2^22 (0.25 m),
 * -2^23 <= vq < 2^23 (0.5 m/s), 0 <= vel_max < 2^30 (64 m/s) and
 * 0 <= amax < 2^30. Then:
 *  - x48 = xi 2^24 + xf (xi = floor(x48 / 2^24), |xi| < 2^30, 0 <= xf <
 *    2^24) gives target48 - x48 = d 2^24 - xf with d = target - xi, so
 *    err = d, or d - 1 when xf is above one half (at one half exactly:
 *    when d <= 0, ties away from zero), in 32 bits (d wraps only when
 *    it is beyond 2^30, never into the range tested);
 *  - |err| <= 2^22 + 1 and |vq| <= 2^23 bound the products by 2^29 + 2^7
 *    and 2^30, their difference below 2^31: no saturation;
 *  - |v48 + acmd dt| < 2^47 + 2^54, so vi = floor(v48 / 2^24) fits int32,
 *    and -vel_max <= vi < vel_max proves |v48| < vmax (no clamp);
 *  - v48 = vi 2^24 + vf makes the step round(v48 dt / 2^24) = vi dt +
 *    round(vf dt / 2^24) (ties up, as spi_mul64_up), both 32 x 32-bit
 *    products, exact;
 *  - |step| <= |v48| <= vmax < 2^54, so |x48| stays below 2^55 - 2^24
 *    and its Q24 value fits int32. */
SPI_INLINE int stream_axis_near(sp_q24_t target, int64_t *x48p, int64_t *v48p, int32_t *vqp, int32_t vel_max,
                                int32_t amax, sp_stream_gains_t g, sp_q24_t *x, sp_q24_t *v, sp_q24_t *acc)
{
    int64_t x48 = *x48p;
    int64_t v48 = *v48p;
    int32_t vq = *vqp;
    uint32_t xf = (uint32_t)x48 & 0xFFFFFFu;
    uint32_t vf;
    int32_t d;
    int32_t err;
    int32_t acmd;
    int32_t vi;
    if (x48 < -STREAM_X_NEAR || x48 >= STREAM_X_NEAR || ((uint32_t)vel_max | (uint32_t)amax) >= STREAM_V_NEAR) {
        return 0;
    }
    d = (int32_t)((uint32_t)target - (uint32_t)stream_floor24(x48));
    if ((((uint32_t)d + 0x400000u) | (((uint32_t)vq + 0x800000u) >> 1)) >= 0x800000u) { /* d, vq outside the bounds */
        return 0;
    }
    if (d == 0 && xf == 0u && v48 == 0) { /* at rest on the target */
        *acc = 0;
        *v = 0;
        *x = target;
        return 1;
    }
    err = d - (int32_t)((xf + 0x7FFFFFu + ((uint32_t)(d - 1) >> 31)) >> 24); /* the fraction rounds d down */
    acmd = (int32_t)(stream_mul24(g.w2, err) - stream_mul24(g.two_w, vq));
    acmd = acmd > amax ? amax : (acmd < -amax ? -amax : acmd);
    v48 += (int64_t)acmd * g.dt; /* Q48 */
    vi = stream_floor24(v48);
    if ((uint32_t)vi + (uint32_t)vel_max >= 2u * (uint32_t)vel_max) { /* |v48| may reach vmax */
        int64_t vmax = (int64_t)vel_max * (INT64_C(1) << 24);
        v48 = v48 > vmax ? vmax : (v48 < -vmax ? -vmax : v48);
        vi = stream_floor24(v48);
    }
    vf = (uint32_t)v48 & 0xFFFFFFu;
    x48 += (int64_t)vi * g.dt + (int64_t)(((uint64_t)vf * (uint32_t)g.dt + 0x800000u) >> 24);
    vq = stream_round24(vi, vf);
    *v48p = v48;
    *x48p = x48;
    *vqp = vq;
    *acc = acmd;
    *v = vq;
    *x = stream_round24(stream_floor24(x48), (uint32_t)x48 & 0xFFFFFFu);
    return 1;
}

void sp_stream_step(sp_stream_t *s, const sp_stream_gains_t *g, const sp_move_limits_t *move, sp_motion_t *m,
                    sp_flags_t *flags)
{
    unsigned a;
    sp_stream_gains_t gv = *g;                      /* read once */
    int near_dt = (uint32_t)gv.dt < STREAM_DT_NEAR; /* a tick below 1 s */
    *flags |= g->flags;
    for (a = 0u; a < 3u; ++a) { /* a position and an angle a turn: their fields share the offsets */
        unsigned r = 3u + a;
        if (!near_dt || !stream_axis_near(s->target.pos[a], &s->x[a], &s->v[a], &s->vq[a], move->vel_max[a],
                                          move->acc_max[a], gv, &m->pose.pos[a], &m->vel[a], &m->acc[a])) {
            stream_axis_sat(s->target.pos[a], &s->x[a], &s->v[a], &s->vq[a], move->vel_max[a], move->acc_max[a], g,
                            &m->pose.pos[a], &m->vel[a], &m->acc[a], flags);
        }
        if (!near_dt || !stream_axis_near(s->target.rpy[a], &s->x[r], &s->v[r], &s->vq[r], move->vel_max[r],
                                          move->acc_max[r], gv, &m->pose.rpy[a], &m->rpy_rate[a], &m->rpy_acc[a])) {
            stream_axis_sat(s->target.rpy[a], &s->x[r], &s->v[r], &s->vq[r], move->vel_max[r], move->acc_max[r], g,
                            &m->pose.rpy[a], &m->rpy_rate[a], &m->rpy_acc[a], flags);
        }
    }
}

int sp_stream_settled(const sp_motion_t *m, const sp_pose_t *pose)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (spi_farther(m->pose.pos[k], pose->pos[k], STREAM_SETTLED) ||
            spi_farther(m->pose.rpy[k], pose->rpy[k], STREAM_SETTLED) || spi_farther(m->vel[k], 0, STREAM_SETTLED) ||
            spi_farther(m->rpy_rate[k], 0, STREAM_SETTLED)) {
            return 0;
        }
    }
    return 1;
}
