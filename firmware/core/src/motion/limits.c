/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/motion/limits.h"

#include "model/model_internal.h"
#include "math/fixed_inline.h"

/* v clamped to int32. */
static sp_q24_t clamp32(int64_t v)
{
    return (v < INT32_MIN) ? INT32_MIN : ((v > INT32_MAX) ? INT32_MAX : (sp_q24_t)v);
}

/* The int32 interval [*lo, *hi] of the values v with wmin <= v - home <=
 * wmax (exactly; lo > hi when there is none). */
static void ws_bounds(sp_q24_t home, sp_q24_t wmin, sp_q24_t wmax, sp_q24_t *lo, sp_q24_t *hi)
{
    int64_t l = (int64_t)home + wmin;
    int64_t h = (int64_t)home + wmax;
    if (l > h || l > INT32_MAX || h < INT32_MIN) {
        *lo = INT32_MAX;
        *hi = INT32_MIN;
        return;
    }
    *lo = clamp32(l);
    *hi = clamp32(h);
}

sp_status_t sp_limits_prepare(sp_limits_t *lim, const sp_platform_t *platform, sp_q24_t stroke_margin)
{
    unsigned i;
    if (lim == NULL || platform == NULL) {
        return SP_E_ARG;
    }
    for (i = 0u; i < 3u; ++i) {
        ws_bounds(platform->home.pos[i], platform->workspace_min.pos[i], platform->workspace_max.pos[i], &lim->ws_lo[i],
                  &lim->ws_hi[i]);
        ws_bounds(platform->home.rpy[i], platform->workspace_min.rpy[i], platform->workspace_max.rpy[i],
                  &lim->ws_lo[3u + i], &lim->ws_hi[3u + i]);
    }
    lim->length_min = clamp32((int64_t)platform->leg_length_min + stroke_margin);
    lim->length_max = clamp32((int64_t)platform->leg_length_max - stroke_margin);
    lim->measured_min = clamp32((int64_t)platform->leg_length_min - SP_LEG_LIMIT_TOLERANCE);
    lim->measured_max = clamp32((int64_t)platform->leg_length_max + SP_LEG_LIMIT_TOLERANCE);
    lim->rate_max = platform->leg_velocity_max;
    lim->force_max = platform->force_max;
    lim->joint_reach = 0u;
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *a = platform->platform_joint[i];
        uint64_t l1 = (uint64_t)spi_dist32(a[0], 0) + spi_dist32(a[1], 0) + spi_dist32(a[2], 0);
        if (l1 >= UINT32_MAX) {
            lim->joint_reach = UINT32_MAX;
        } else if (l1 > lim->joint_reach) {
            lim->joint_reach = (uint32_t)l1;
        }
    }
    return SP_OK;
}

int sp_limits_lengths_ok(const sp_limits_t *lim, const sp_q24_t length[SP_LEGS])
{
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        if (length[i] < lim->length_min || length[i] > lim->length_max) {
            return 0;
        }
    }
    return 1;
}

int sp_limits_legs_reachable(const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *pose,
                             sp_q24_t length[SP_LEGS])
{
    sp_ik_t ik;
    unsigned i;
    spi_orientation_sc(pose->rpy, &ik.rot, ik.sc);
    if (spi_ik_lengths(platform, pose, &ik) != SP_OK || !sp_limits_lengths_ok(lim, ik.length)) {
        return 0; /* the lengths only: no unit vectors needed */
    }
    if (length != NULL) {
        for (i = 0u; i < SP_LEGS; ++i) {
            length[i] = ik.length[i];
        }
    }
    return 1;
}

int sp_limits_pose_reachable(const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *pose,
                             sp_q24_t length[SP_LEGS])
{
    return sp_limits_in_workspace(lim, pose) && sp_limits_legs_reachable(lim, platform, pose, length);
}

int sp_limits_reachable_near(const sp_limits_t *lim, const sp_pose_t *base, const sp_q24_t base_length[SP_LEGS],
                             const sp_pose_t *pose)
{
    uint64_t dpos = 0u;
    uint64_t drot = 0u;
    uint64_t delta;
    int64_t lo;
    int64_t hi;
    uint32_t span;
    unsigned k;

    for (k = 0u; k < 3u; ++k) {
        dpos += spi_dist32(pose->pos[k], base->pos[k]);
        drot += spi_dist32(pose->rpy[k], base->rpy[k]);
    }
    if (drot >= (UINT64_C(1) << 31) || lim->joint_reach == UINT32_MAX) {
        return 0; /* more than 128 rad or a 256 m platform: not worth bounding */
    }
    /* Q24 x Q24 -> Q24, truncated: +1; a 32 x 32-bit product */
    delta = dpos + (((uint64_t)lim->joint_reach * (uint32_t)drot) >> 24) + 5u;
    if (delta >= (UINT64_C(1) << 31)) {
        return 0;
    }
    /* every leg l - delta >= length_min and l + delta <= length_max, i.e.
     * l in [lo, hi]: an int32 interval when not empty (length_min <= lo,
     * hi <= length_max), each leg one unsigned compare as in
     * sp_limits_setpoints_ok */
    lo = (int64_t)lim->length_min + (int64_t)delta;
    hi = (int64_t)lim->length_max - (int64_t)delta;
    if (lo > hi) {
        return 0;
    }
    span = (uint32_t)(hi - lo);
    for (k = 0u; k < SP_LEGS; ++k) {
        if ((uint32_t)base_length[k] - (uint32_t)lo > span) {
            return 0;
        }
    }
    return 1;
}

int sp_limits_pose_reachable_from(const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *base,
                                  const sp_q24_t base_length[SP_LEGS], const sp_pose_t *pose)
{
    if (!sp_limits_in_workspace(lim, pose)) {
        return 0;
    }
    if (base_length != NULL && sp_limits_reachable_near(lim, base, base_length, pose)) {
        return 1; /* sufficient: the IK would say the same */
    }
    return sp_limits_legs_reachable(lim, platform, pose, NULL);
}

int sp_limits_setpoints_ok(const sp_limits_t *lim, const sp_q24_t length[SP_LEGS], const sp_q24_t rate[SP_LEGS],
                           const sp_q8_t force[SP_LEGS])
{
    const sp_q24_t vmax = lim->rate_max;
    const sp_q8_t fmax = lim->force_max;
    uint32_t lspan;
    uint32_t vspan;
    uint32_t fspan;
    unsigned i;
    if (lim->length_min > lim->length_max || vmax < 0 || fmax < 0) {
        return 0; /* no value lies in an empty interval */
    }
    /* each test lo <= x <= hi as one unsigned compare, (x - lo) mod 2^32
     * <= hi - lo (exact for int32 x, lo <= hi); |x| <= m as x + m in
     * [0, 2 m] (m <= 2^31 - 1: 2 m fits uint32) */
    lspan = (uint32_t)lim->length_max - (uint32_t)lim->length_min;
    vspan = 2u * (uint32_t)vmax;
    fspan = 2u * (uint32_t)fmax;
    for (i = 0u; i < SP_LEGS; ++i) {
        if ((uint32_t)length[i] - (uint32_t)lim->length_min > lspan || (uint32_t)rate[i] + (uint32_t)vmax > vspan ||
            (uint32_t)force[i] + (uint32_t)fmax > fspan) {
            return 0;
        }
    }
    return 1;
}

sp_status_t sp_check_legs(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_q24_t rate[SP_LEGS],
                          const sp_q8_t force[SP_LEGS], sp_leg_limits_t *report)
{
    unsigned i;

    if (platform == NULL || length == NULL || report == NULL) {
        return SP_E_ARG;
    }
    report->too_short = 0u;
    report->too_long = 0u;
    report->too_fast = 0u;
    report->over_force = 0u;
    for (i = 0u; i < SP_LEGS; ++i) {
        uint32_t bit = UINT32_C(1) << i;
        if (length[i] < platform->leg_length_min) {
            report->too_short |= bit;
        }
        if (length[i] > platform->leg_length_max) {
            report->too_long |= bit;
        }
        if (rate != NULL && (rate[i] > platform->leg_velocity_max || rate[i] < -platform->leg_velocity_max)) {
            report->too_fast |= bit;
        }
        if (force != NULL && (force[i] > platform->force_max || force[i] < -platform->force_max)) {
            report->over_force |= bit;
        }
    }
    return (report->too_short | report->too_long | report->too_fast | report->over_force) ? SP_E_RANGE : SP_OK;
}
