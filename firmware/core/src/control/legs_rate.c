/* SPDX-License-Identifier: Apache-2.0 */
/*
 * legs_rate.c - the legs' rates of the motions the controller plans:
 * a planned move's speed limits and the stream filter's, each tick of a
 * stream, so that no leg is asked beyond leg_velocity_max (issue 35).
 * Compiled for speed in the Cortex-M4 builds (a STREAM tick runs
 * spi_stream_limits).
 */
#include "control/control_internal.h"

#include "math/fixed_inline.h"

/* A leg's rate is n . (v + w x R a) (n the leg's unit direction, a its
 * platform joint), at most |v| + |w| |a|, and |w| <= |roll'| + |pitch'| +
 * |yaw'| (each Euler rate turns the platform about a unit axis): so
 *   |rate| <= |x'| + |y'| + |z'| + arm (|roll'| + |pitch'| + |yaw'|)
 * with arm the joints' largest distance from o' (prep.arm_max). With
 * frames the motion is the tool's (T in W), whose point lies |t| from o'
 * (v_o' = v_T - w x R t, |v| unchanged by W's rotation): arm + |t|.
 * Q24 m; below 2^27 (joints within 1 m of o' ... tool points within 5 m:
 * arm + |t| < 8 m). */
void spi_rate_prepare(sp_ctrl_t *ctrl)
{
    int64_t w = ctrl->prep.arm_max;
    unsigned k;
    if (!ctrl->frames.identity) {
        uint64_t s2 = 0u; /* Q48, below 3 (5 m)^2 2^48 < 2^55 */
        for (k = 0u; k < 3u; ++k) {
            s2 += (uint64_t)((int64_t)ctrl->frames.tool.pos[k] * ctrl->frames.tool.pos[k]);
        }
        w += (int64_t)sp_isqrt64(s2) + 1; /* rounded up */
    }
    ctrl->rate_weight = w;
    (void)sp_recip_prepare(6 * w, &ctrl->rate_grow); /* w <= 0 (no joints): unused, see below */
}

/* The legs' rate the planned motions keep below: rate_max less 1/64 (the
 * samples' and the Jacobian's rounding, a few LSB). Q24 m/s. */
static int64_t leg_budget(const sp_ctrl_t *ctrl)
{
    int64_t r = ctrl->prep.limits.rate_max;
    return (r > 0) ? r - (r >> 6) : 0;
}

static int64_t axis_value(const sp_pose_t *p, unsigned a)
{
    return (a < 3u) ? (int64_t)p->pos[a] : (int64_t)p->rpy[a - 3u];
}

sp_status_t spi_move_plan_legs(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *from, const sp_pose_t *to)
{
    sp_move_limits_t lim = cfg->move;
    int64_t w = ctrl->rate_weight;
    uint64_t budget = (uint64_t)leg_budget(ctrl);
    uint64_t d[6];
    uint64_t sum = 0u; /* Q24 m: sum of |D| on x, y, z and w |D| on the angles, below 2^37 */
    unsigned a;
    for (a = 0u; a < 6u; ++a) {
        d[a] = (uint64_t)spi_abs64(axis_value(to, a) - axis_value(from, a)); /* below 2^32 */
        sum += (a < 3u) ? d[a] : ((d[a] * (uint64_t)w + ((UINT64_C(1) << 24) - 1u)) >> 24);
    }
    /* The quintic's peak speed 1.875 D / T on every axis at once: the
     * bound above stays within the budget when T >= 1.875 sum / budget,
     * i.e. every moving axis's speed limit within budget |D| / sum
     * (rounded up: the largest axis's T is short of the bound by a
     * relative 2^-20 at most, well within the budget's 1/64) */
    for (a = 0u; a < 6u && sum > 0u && budget > 0u; ++a) {
        if (d[a] != 0u) {
            uint64_t v = (budget * d[a] + sum - 1u) / sum; /* budget < 2^31, d < 2^32: below 2^63 */
            if (v < (uint64_t)lim.vel_max[a]) {
                lim.vel_max[a] = (sp_q24_t)v; /* >= 1 */
            }
        }
    }
    return sp_move_plan(&ctrl->move, from, to, &lim, cfg->tick_us);
}

void spi_stream_limits(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    sp_move_limits_t *lim = &ctrl->stream_lim;
    int64_t w = ctrl->rate_weight;
    int64_t used = 0; /* Q24 m/s: the bound above at the filter's last velocities */
    int64_t room;
    int64_t grow[2];
    int32_t sixth;
    unsigned a;
    *lim = cfg->move;
    for (a = 0u; a < 6u; ++a) {
        int64_t v = spi_abs64((int64_t)ctrl->stream.vq[a]); /* below 2^31 */
        used += (a < 3u) ? v : ((v * w + ((INT64_C(1) << 24) - 1)) >> 24);
    }
    /* each axis may grow its speed by a sixth of the room left (an angle:
     * that divided by w), so that the six together stay within it; no
     * axis is made slower than it goes */
    room = leg_budget(ctrl) - used;
    room = (room > 0) ? room : 0;
    sixth = (int32_t)room / 6; /* room < 2^31: the M4's divide, not a 64-bit library call */
    grow[0] = sixth;
    /* (room 2^24) / (6 w) exactly, room < 2^31 (sp_recip_div: no 64-bit division each tick) */
    grow[1] = (w > 0) ? sp_recip_div((uint32_t)room, &ctrl->rate_grow) : (int64_t)INT32_MAX;
    for (a = 0u; a < 6u; ++a) {
        int64_t l = spi_abs64((int64_t)ctrl->stream.vq[a]) + grow[(a < 3u) ? 0u : 1u];
        if (l < (int64_t)lim->vel_max[a]) {
            lim->vel_max[a] = (sp_q24_t)l;
        }
    }
}
