/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/model/kinematics.h"

#include <string.h>

#include "model/model_internal.h"
#include "math/fixed_inline.h"

#define LEG_COMPONENT_MAX (INT32_C(1) << 30) /* 64 m in Q24 */
#define LEG_LENGTH_MIN SP_Q24_MILLI(1)       /* 1 mm */

/* T's entries that yaw does not enter (its third column), from the sines
 * and cosines sc = {sin, cos} of roll, pitch, yaw (from sp_sincos_q24:
 * each within 1.05 LSB of Q30, at most 2^30 + 1), and tilt = {sin pitch
 * sin roll, sin pitch cos roll}, the products the yaw entries take. */
SPI_INLINE void rot_tilt(const sp_q30_t sc[6], sp_rot_t *rot, sp_q30_t tilt[2])
{
    sp_q30_t sr = sc[0];
    sp_q30_t cr = sc[1];
    sp_q30_t sp = sc[2];
    sp_q30_t cp = sc[3];

    tilt[0] = spi_mul30_up(sp, sr);
    tilt[1] = spi_mul30_up(sp, cr);
    rot->t[0][2] = -sp;
    rot->t[1][2] = spi_mul30_up(cp, sr);
    rot->t[2][2] = spi_mul30_up(cp, cr);
}

/* T's entries that yaw enters (its first two columns), from sc and
 * rot_tilt's tilt. Entries with two terms are rounded once, from the
 * exact sum. */
SPI_INLINE void rot_yaw(const sp_q30_t sc[6], const sp_q30_t tilt[2], sp_rot_t *rot)
{
    sp_q30_t sr = sc[0];
    sp_q30_t cr = sc[1];
    sp_q30_t cp = sc[3];
    sp_q30_t sy = sc[4];
    sp_q30_t cy = sc[5];
    sp_q30_t spsr = tilt[0];
    sp_q30_t spcr = tilt[1];

    /* T = (Rz(yaw) Ry(pitch) Rx(roll))^T: row r of T is column r of the
     * column-vector rotation. */
    rot->t[0][0] = spi_mul30_up(cy, cp);
    rot->t[0][1] = spi_mul30_up(sy, cp);
    rot->t[1][0] = spi_dot30_up(cy, spsr, -sy, cr);
    rot->t[1][1] = spi_dot30_up(sy, spsr, cy, cr);
    rot->t[2][0] = spi_dot30_up(cy, spcr, sy, sr);
    rot->t[2][1] = spi_dot30_up(sy, spcr, -cy, sr);
}

/* Are roll and pitch 0 (sc as sp_sincos_q24 gives them: sin 0 = 0,
 * cos 0 = 2^30)? */
SPI_INLINE int level(const sp_q30_t sc[6])
{
    return (sc[0] | sc[2]) == 0 && sc[1] == SP_Q30_ONE && sc[3] == SP_Q30_ONE;
}

/* rot_yaw for level sc: each product of a sine or cosine with cos 0 =
 * 2^30 (or sin 0 = 0, and tilt is then 0) rounds to the factor itself, so
 * T's yaw entries are yaw's sine and cosine. */
SPI_INLINE void rot_level(const sp_q30_t sc[6], sp_rot_t *rot)
{
    rot->t[0][0] = sc[5];
    rot->t[0][1] = sc[4];
    rot->t[1][0] = -sc[4];
    rot->t[1][1] = sc[5];
    rot->t[2][0] = 0;
    rot->t[2][1] = 0;
}

/* T from the sines and cosines sc = {sin, cos} of roll, pitch, yaw:
 * rot_tilt and rot_yaw. */
void spi_rot_from_sincos(const sp_q30_t sc[6], sp_rot_t *rot)
{
    sp_q30_t tilt[2];

    rot_tilt(sc, rot, tilt);
    rot_yaw(sc, tilt, rot);
}

/* T of the angles, keeping their sines and cosines in sc. */
void spi_orientation_sc(const sp_q24_t rpy[3], sp_rot_t *rot, sp_q30_t sc[6])
{
    sp_sincos_q24(rpy[0], &sc[0], &sc[1]);
    sp_sincos_q24(rpy[1], &sc[2], &sc[3]);
    sp_sincos_q24(rpy[2], &sc[4], &sc[5]);
    spi_rot_from_sincos(sc, rot);
}

sp_status_t sp_orientation(const sp_q24_t rpy[3], sp_rot_t *rot)
{
    sp_q30_t sc[6];

    if (rpy == NULL || rot == NULL) {
        return SP_E_ARG;
    }
    spi_orientation_sc(rpy, rot, sc);
    return SP_OK;
}

#if defined(__GNUC__)
#define SPI_UNLIKELY(x) __builtin_expect((x), 0)
#define SPI_COLD __attribute__((cold, noinline))
#else
#define SPI_UNLIKELY(x) (x)
#define SPI_COLD
#endif

/* *leg = l = am + pos_c - b_c and 1 when l fits int32 (the int64 path,
 * taken when an int32 intermediate overflows, checks |l| < 2^30 itself);
 * 0 when l is out of that range. On the int32 path the caller tests
 * |l| < 2^30 (64 m) on the three components at once (range_bits). */
SPI_INLINE int leg_component(int32_t am, int32_t pos_c, int32_t b_c, int32_t *leg)
{
#if defined(__GNUC__)
    int32_t d;
    int32_t l;
    /* int32 arithmetic with the overflow flag; the int64 path below only
     * when an intermediate leaves int32 */
    if (!SPI_UNLIKELY(__builtin_sub_overflow(pos_c, b_c, &d) || __builtin_add_overflow(am, d, &l))) {
        *leg = l;
        return 1;
    }
#endif
    {
        int64_t l64 = (int64_t)am + pos_c - b_c;
        if (l64 >= LEG_COMPONENT_MAX || l64 <= -LEG_COMPONENT_MAX) {
            return 0;
        }
        *leg = (int32_t)l64;
        return 1;
    }
}

/* y = l + (l < 0 ? -1 : 0) + 2^30 modulo 2^32 has its top bit clear
 * exactly when -2^30 < l < 2^30: l in [0, 2^30) gives [2^30, 2^31),
 * l in (-2^30, 0) gives [0, 2^30 - 1); l in [2^30, 2^31) gives
 * [2^31, 3 2^30), l = -2^30 gives 2^32 - 1, l in [-2^31, -2^30) gives
 * [3 2^30 - 1, 2^32 - 1). So the OR of three has its top bit clear exactly
 * when all three are in range. */
SPI_INLINE uint32_t range_bits(int32_t l)
{
    return (uint32_t)l + (uint32_t)(l >> 31) + UINT32_C(0x40000000);
}

/* The arm (A_im T)_c = sum_r a_r T[r][c] of one leg (Q24 x Q30: the exact
 * sum of three products, below 3 * 2^31 (2^30 + 3) < 2^63, plus the
 * rounding half, then >> 30, ties up; saturated and flagged beyond int32.
 * T's columns are unit vectors, so |arm| <= |a| (1 + 2^-28)). */
SPI_INLINE int32_t arm_component(const int32_t a[3], const sp_rot_t *rot, unsigned c, sp_flags_t *flags)
{
    int64_t acc =
        (int64_t)a[0] * rot->t[0][c] + (int64_t)a[1] * rot->t[1][c] + (int64_t)a[2] * rot->t[2][c] + (INT64_C(1) << 29);
    return spi_narrow_floor(acc, 30u, flags);
}

/* The length of leg i, l = (l0, l1, l2) with every |l_c| < 2^30 (stored
 * into ik->leg[i]): one correctly rounded square root of the exact |l|^2.
 * Returns 0 for a leg shorter than 1 mm, else 1. */
SPI_INLINE int leg_length(sp_ik_t *ik, unsigned i, int32_t l0, int32_t l1, int32_t l2)
{
    uint64_t len2;
    uint32_t hi;

    ik->leg[i][0] = l0;
    ik->leg[i][1] = l1;
    ik->leg[i][2] = l2;
    /* |l|^2, Q48: each |l_c| < 2^30, so the sum is below 3 * 2^60 */
    len2 = (uint64_t)((int64_t)l0 * l0 + (int64_t)l1 * l1 + (int64_t)l2 * l2);
    hi = (uint32_t)(len2 >> 32);
    if (hi != 0u) {
        /* |l| >= 2^16 (3.9 mm), above the 1 mm minimum. len2 2^z with z
         * even has its top word in [2^30, 2^32); hi < 3 * 2^28 makes
         * z >= 2. r = floor(sqrt(len2 2^z)), and floor(2 |l|) =
         * r >> (z/2 - 1); round(|l|) = (floor(2 |l|) + 1) >> 1 (no
         * ties: |l|^2 is an integer). Below 2^31. */
        unsigned z = spi_clz32(hi) & ~1u;
        uint32_t lo = (uint32_t)len2;
        uint32_t r = spi_sqrt_norm((hi << z) | (lo >> (32u - z)), lo << z);
        ik->length[i] = (sp_q24_t)(((r >> ((z >> 1) - 1u)) + 1u) >> 1);
    } else {
        ik->length[i] = (sp_q24_t)sp_isqrt64(len2); /* below 2^16 */
        if (ik->length[i] < LEG_LENGTH_MIN) {
            return 0;
        }
    }
    return 1;
}

/* The unit vector u = l / |l| (Q24 / Q24 -> Q30) of leg i of a successful
 * ik_lengths, l = (l0, l1, l2) its leg and m its length, with one
 * reciprocal: 1/|l| = inv 2^z / 2^62 with z = clz(|l|), so
 * u_c = l_c inv 2^z / 2^32 = (l_c 2^(z-1)) inv / 2^31, rounded (ties
 * up). |l_c| <= |l| (the rounded length is at least the floor of the root)
 * < 2^(32-z), so l_c 2^(z-1) fits int32: a constant shift. inv is never
 * above the exact reciprocal and has 31 significant bits (relative error
 * below 2^-28): the error is at most 3 LSB of Q30 and |u_c| <= 2^30. */
SPI_INLINE void leg_unit(sp_ik_t *ik, unsigned i, int32_t l0, int32_t l1, int32_t l2, uint32_t m)
{
    unsigned z = spi_clz32(m); /* >= 1: m in [2^14, 2^31) */
    uint32_t q = spi_recip_norm(m << z);
    int32_t inv = (q > 0x7FFFFFFFu) ? 0x7FFFFFFF : (int32_t)q; /* as spi_recip */
    int32_t sc = INT32_C(1) << (z - 1u);
    /* l_c 2^(z-1) is exact, see above */
    ik->unit[i][0] = (sp_q30_t)(((int64_t)(l0 * sc) * inv + (INT64_C(1) << 30)) >> 31);
    ik->unit[i][1] = (sp_q30_t)(((int64_t)(l1 * sc) * inv + (INT64_C(1) << 30)) >> 31);
    ik->unit[i][2] = (sp_q30_t)(((int64_t)(l2 * sc) * inv + (INT64_C(1) << 30)) >> 31);
}

/* Leg i of a pose from its arm (ik->arm[i]): the leg vector and its
 * length (leg_length). Returns 0 for a leg component of 64 m or more or a
 * leg shorter than 1 mm, else 1. */
SPI_INLINE int leg_of_arm(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik, unsigned i)
{
    const int32_t *b = platform->base_joint[i];
    int32_t l0;
    int32_t l1;
    int32_t l2;

    if (!leg_component(ik->arm[i][0], pose->pos[0], b[0], &l0) ||
        !leg_component(ik->arm[i][1], pose->pos[1], b[1], &l1) ||
        !leg_component(ik->arm[i][2], pose->pos[2], b[2], &l2)) {
        return 0;
    }
    if (((range_bits(l0) | range_bits(l1) | range_bits(l2)) & UINT32_C(0x80000000)) != 0u) {
        return 0; /* a component reaches 64 m */
    }
    return leg_length(ik, i, l0, l1, l2);
}

/* leg_of_arm for legs that fit (legs_fit), and the leg's unit vector
 * (leg_unit) from the values at hand: every component is arm + pos - base
 * with |arm_c| < 2^26, |pos_c| <= 2^28 and |b_c| <= 2^27, so it is below
 * 2^29 in magnitude: no int32 overflow and no component of 64 m, the
 * tests leg_of_arm makes cannot fail and are left out. */
SPI_INLINE int leg_fit(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik, unsigned i)
{
    const int32_t *b = platform->base_joint[i];
    int32_t l0 = ik->arm[i][0] + (pose->pos[0] - b[0]);
    int32_t l1 = ik->arm[i][1] + (pose->pos[1] - b[1]);
    int32_t l2 = ik->arm[i][2] + (pose->pos[2] - b[2]);

    if (!leg_length(ik, i, l0, l1, l2)) {
        return 0;
    }
    leg_unit(ik, i, l0, l1, l2, (uint32_t)ik->length[i]);
    return 1;
}

/* Do the legs of a pose fit (leg_fit), for a platform with
 * spi_legs_fit? Its position within 16 m (Q24: [-2^28, 2^28)) in each
 * axis. */
SPI_INLINE int pose_fits(const sp_pose_t *pose)
{
    /* p in [-2^28, 2^28) exactly when p + 2^28 is in [0, 2^29) */
    const uint32_t off = UINT32_C(1) << 28;
    uint32_t out = ((uint32_t)pose->pos[0] + off) | ((uint32_t)pose->pos[1] + off) | ((uint32_t)pose->pos[2] + off);
    return (out >> 29) == 0u;
}

/* Inverse kinematics of a pose whose orientation ik->rot is already set:
 * arms, legs and lengths. Every leg costs three 3-term dot products for
 * its arm (exact 64-bit sums, rounded) and leg_of_arm. */
sp_status_t spi_ik_lengths(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik)
{
    sp_flags_t flags = 0u;
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        /* copies: the stores to ik below could alias the platform */
        const int32_t a[3] = {platform->platform_joint[i][0], platform->platform_joint[i][1],
                              platform->platform_joint[i][2]};
        ik->arm[i][0] = arm_component(a, &ik->rot, 0u, &flags);
        ik->arm[i][1] = arm_component(a, &ik->rot, 1u, &flags);
        ik->arm[i][2] = arm_component(a, &ik->rot, 2u, &flags);
        if (!leg_of_arm(platform, pose, ik, i)) {
            return SP_E_RANGE;
        }
    }
    return sp_flags_status(flags);
}

/* arm_component for a joint a within 2 m in each axis: the exact sum over
 * 2^30 is below 2^26, so the shift alone is its value. */
SPI_INLINE int32_t arm_near(const int32_t a[3], const sp_rot_t *rot, unsigned c)
{
    return (int32_t)(((int64_t)a[0] * rot->t[0][c] + (int64_t)a[1] * rot->t[1][c] + (int64_t)a[2] * rot->t[2][c] +
                      (INT64_C(1) << 29)) >>
                     30);
}

/* leg_of_arm for every leg of ik->arm: SP_E_RANGE when one fails. */
static sp_status_t ik_legs(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik)
{
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        if (!leg_of_arm(platform, pose, ik, i)) {
            return SP_E_RANGE;
        }
    }
    return SP_OK;
}

/* spi_ik_lengths of ik->rot for a platform with spi_joints_near (every
 * joint within 2 m in each axis: each arm's exact sum over 2^30 is below
 * 2^26, so the shift alone is arm_component's value, never saturated),
 * the same bits and status. A turn about the vertical alone (flat: the
 * caller's level sc, roll = pitch = 0, so that T's third row and column
 * are exactly e_z) makes each arm's x and y from two products and keeps
 * its height a_z: the products left out are exactly 0 and a_z 2^30 rounds
 * to a_z. With fit (legs_fit: the platform's spi_legs_fit and pose_fits)
 * each leg follows its arm in the same pass, by leg_fit. Out of line: the
 * ticks whose orientation holds do not carry its registers. */
SPI_NOINLINE static sp_status_t ik_lengths_near(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik,
                                                int fit, int flat)
{
    const sp_rot_t *rot = &ik->rot;
    const int64_t half = INT64_C(1) << 29;
    unsigned k;

    if (flat) {
        for (k = 0u; k < SP_LEGS; ++k) {
            const int32_t a0 = platform->platform_joint[k][0];
            const int32_t a1 = platform->platform_joint[k][1];
            ik->arm[k][2] = platform->platform_joint[k][2];
            ik->arm[k][0] = (int32_t)(((int64_t)a0 * rot->t[0][0] + (int64_t)a1 * rot->t[1][0] + half) >> 30);
            ik->arm[k][1] = (int32_t)(((int64_t)a0 * rot->t[0][1] + (int64_t)a1 * rot->t[1][1] + half) >> 30);
            if (fit && !leg_fit(platform, pose, ik, k)) {
                return SP_E_RANGE;
            }
        }
    } else {
        for (k = 0u; k < SP_LEGS; ++k) {
            const int32_t a[3] = {platform->platform_joint[k][0], platform->platform_joint[k][1],
                                  platform->platform_joint[k][2]};
            ik->arm[k][0] = arm_near(a, rot, 0u);
            ik->arm[k][1] = arm_near(a, rot, 1u);
            ik->arm[k][2] = arm_near(a, rot, 2u);
            if (fit && !leg_fit(platform, pose, ik, k)) {
                return SP_E_RANGE;
            }
        }
    }
    return fit ? SP_OK : ik_legs(platform, pose, ik);
}

/* spi_ik_lengths with the arms (of ik->rot) given: leg_of_arm alone (or
 * leg_fit with fit, see ik_lengths_near). */
static sp_status_t ik_legs_kept(const sp_platform_t *platform, const sp_pose_t *pose, const sp_q24_t arm[SP_LEGS][3],
                                sp_ik_t *ik, int fit)
{
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        ik->arm[i][0] = arm[i][0];
        ik->arm[i][1] = arm[i][1];
        ik->arm[i][2] = arm[i][2];
        if (!(fit ? leg_fit(platform, pose, ik, i) : leg_of_arm(platform, pose, ik, i))) {
            return SP_E_RANGE;
        }
    }
    return SP_OK;
}

/* The unit vectors of a successful ik_lengths: leg_unit of every leg. */
void spi_ik_units(sp_ik_t *ik)
{
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        leg_unit(ik, i, ik->leg[i][0], ik->leg[i][1], ik->leg[i][2], (uint32_t)ik->length[i]);
    }
}

sp_status_t sp_inverse_kinematics(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik)
{
    sp_status_t st;

    if (platform == NULL || pose == NULL || ik == NULL) {
        return SP_E_ARG;
    }
    spi_orientation_sc(pose->rpy, &ik->rot, ik->sc);
    st = spi_ik_lengths(platform, pose, ik);
    if (st == SP_OK) {
        spi_ik_units(ik);
    }
    return st;
}

/* spi_orient_update, inlined into the IK (one call fewer a tick). */
SPI_INLINE int orient_update(sp_orient_keep_t *keep, const sp_q24_t rpy[3], int *flat)
{
    unsigned k;
    int changed = !keep->valid;
    int tilted = !keep->valid; /* roll or pitch changed */
    *flat = 0;
    for (k = 0u; k < 3u; ++k) {
        if (!keep->valid || rpy[k] != keep->rpy[k]) {
            sp_sincos_q24(rpy[k], &keep->sc[2u * k], &keep->sc[2u * k + 1u]);
            keep->rpy[k] = rpy[k];
            changed = 1;
            tilted |= (k < 2u);
        }
    }
    if (tilted) {
        rot_tilt(keep->sc, &keep->rot, keep->tilt);
    }
    if (changed) {
        /* T's yaw entries; its third column and tilt kept while roll and
         * pitch hold (a turn in yaw alone): spi_rot_from_sincos' T */
        *flat = level(keep->sc);
        if (*flat) {
            rot_level(keep->sc, &keep->rot);
        } else {
            rot_yaw(keep->sc, keep->tilt, &keep->rot);
        }
        keep->valid = 1u;
        keep->arms_valid = 0u;  /* the arms were of the old T */
        keep->rates_valid = 0u; /* the body rates were of the old sines */
    }
    return changed;
}

int spi_orient_update(sp_orient_keep_t *keep, const sp_q24_t rpy[3], int *flat)
{
    return orient_update(keep, rpy, flat);
}

sp_status_t sp_inverse_kinematics_kept(const sp_platform_t *platform, const sp_pose_t *pose, sp_orient_keep_t *keep,
                                       sp_ik_t *ik)
{
    sp_status_t st;
    unsigned k;
    int changed;
    int fit;
    int flat = 0; /* roll = pitch = 0 (level) */

    if (keep == NULL) {
        return sp_inverse_kinematics(platform, pose, ik);
    }
    if (platform == NULL || pose == NULL || ik == NULL) {
        return SP_E_ARG;
    }
    if (!keep->valid || keep->near_of != platform) {
        keep->near = (uint8_t)spi_joints_near(platform);
        keep->fit = (uint8_t)spi_legs_fit(platform);
        keep->near_of = platform;
    }
    fit = keep->fit && pose_fits(pose);
    changed = orient_update(keep, pose->rpy, &flat);
    if (keep->fresh) {
        /* made this tick by the frames (same angles): a turning reference */
        changed = 1;
        flat = level(keep->sc);
        keep->fresh = 0u;
    }
    ik->rot = keep->rot;
    memcpy(ik->sc, keep->sc, sizeof ik->sc);
    if (changed) {
        /* a turning reference: no arms kept (keeping them would cost the
         * turning ticks) */
        keep->arms_valid = 0u;
        st = keep->near ? ik_lengths_near(platform, pose, ik, fit, flat) : spi_ik_lengths(platform, pose, ik);
    } else {
        if (!keep->arms_valid || keep->platform != platform) {
            /* the orientation held a second tick: its arms, as
             * spi_ik_lengths makes them (functions of T and the platform
             * only), kept for the ticks it holds on */
            keep->arm_flags = 0u;
            for (k = 0u; k < SP_LEGS; ++k) {
                const int32_t a[3] = {platform->platform_joint[k][0], platform->platform_joint[k][1],
                                      platform->platform_joint[k][2]};
                keep->arm[k][0] = arm_component(a, &keep->rot, 0u, &keep->arm_flags);
                keep->arm[k][1] = arm_component(a, &keep->rot, 1u, &keep->arm_flags);
                keep->arm[k][2] = arm_component(a, &keep->rot, 2u, &keep->arm_flags);
            }
            keep->platform = platform;
            keep->arms_valid = 1u;
        }
        st = ik_legs_kept(platform, pose, (const sp_q24_t(*)[3])keep->arm, ik, fit);
        if (st == SP_OK) {
            st = sp_flags_status(keep->arm_flags); /* spi_ik_lengths' status */
        }
    }
    if (st == SP_OK && !fit) {
        spi_ik_units(ik); /* leg_fit made them with the legs */
    }
    return st;
}

sp_status_t sp_leg_stretch(const sp_ik_t *ik, const sp_ik_t *home_ik, sp_q24_t stretch[SP_LEGS])
{
    sp_flags_t flags = 0u;
    unsigned i;

    if (ik == NULL || home_ik == NULL || stretch == NULL) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        stretch[i] = sp_sub(ik->length[i], home_ik->length[i], &flags);
    }
    return sp_flags_status(flags);
}

/* Accumulates v (Q24) x c (Q30) into a Q54 int64 sum, saturating. */
SPI_INLINE void acc_term(int64_t *acc, int32_t v, int32_t c, sp_flags_t *flags)
{
    *acc = spi_add64(*acc, (int64_t)v * c, flags);
}

sp_status_t sp_body_rates(const sp_q24_t rpy[3], const sp_q24_t rpy_rate[3], const sp_q24_t rpy_acc[3],
                          sp_q24_t omega[3], sp_q24_t omega_dot[3])
{
    sp_q30_t sc[6];

    if (rpy == NULL) {
        return SP_E_ARG;
    }
    sp_sincos_q24(rpy[0], &sc[0], &sc[1]);
    sp_sincos_q24(rpy[1], &sc[2], &sc[3]);
    sc[4] = 0; /* yaw does not enter */
    sc[5] = SP_Q30_ONE;
    return sp_body_rates_sc(sc, rpy_rate, rpy_acc, omega, omega_dot);
}

/* sp_body_rates_sc for any sc: every sum saturating. */
SPI_COLD static sp_status_t body_rates_wide(const sp_q30_t sc[6], const sp_q24_t rpy_rate[3], const sp_q24_t rpy_acc[3],
                                            sp_q24_t omega[3], sp_q24_t omega_dot[3])
{
    sp_flags_t flags = 0u;
    sp_q30_t sr;
    sp_q30_t cr;
    sp_q30_t sp;
    sp_q30_t cp;
    sp_q24_t dr;
    sp_q24_t dp;
    sp_q24_t dy;
    sp_q24_t dp_dr;
    sp_q24_t dy_dp;
    sp_q24_t dy_dr;
    int64_t a;

    sr = sc[0];
    cr = sc[1];
    sp = sc[2];
    cp = sc[3];
    dr = rpy_rate[0];
    dp = rpy_rate[1];
    dy = rpy_rate[2];

    /* eq (10) */
    a = 0;
    acc_term(&a, dr, SP_Q30_ONE, &flags);
    acc_term(&a, dy, -sp, &flags);
    omega[0] = spi_narrow_away(a, 30u, &flags);
    a = 0;
    acc_term(&a, dp, cr, &flags);
    acc_term(&a, dy, spi_mul30_away(cp, sr), &flags);
    omega[1] = spi_narrow_away(a, 30u, &flags);
    a = 0;
    acc_term(&a, dp, -sr, &flags);
    acc_term(&a, dy, spi_mul30_away(cp, cr), &flags);
    omega[2] = spi_narrow_away(a, 30u, &flags);

    /* d/dt of eq (10): the angle accelerations plus the products of rates. */
    dp_dr = spi_mul_away(dp, dr, 24u, &flags);
    dy_dp = spi_mul_away(dy, dp, 24u, &flags);
    dy_dr = spi_mul_away(dy, dr, 24u, &flags);
    a = 0;
    acc_term(&a, rpy_acc[0], SP_Q30_ONE, &flags);
    acc_term(&a, rpy_acc[2], -sp, &flags);
    acc_term(&a, dy_dp, -cp, &flags);
    omega_dot[0] = spi_narrow_away(a, 30u, &flags);
    a = 0;
    acc_term(&a, rpy_acc[1], cr, &flags);
    acc_term(&a, dp_dr, -sr, &flags);
    acc_term(&a, rpy_acc[2], spi_mul30_away(cp, sr), &flags);
    acc_term(&a, dy_dp, -spi_mul30_away(sp, sr), &flags);
    acc_term(&a, dy_dr, spi_mul30_away(cp, cr), &flags);
    omega_dot[1] = spi_narrow_away(a, 30u, &flags);
    a = 0;
    acc_term(&a, rpy_acc[1], -sr, &flags);
    acc_term(&a, dp_dr, -cr, &flags);
    acc_term(&a, rpy_acc[2], spi_mul30_away(cp, cr), &flags);
    acc_term(&a, dy_dp, -spi_mul30_away(sp, cr), &flags);
    acc_term(&a, dy_dr, -spi_mul30_away(cp, sr), &flags);
    omega_dot[2] = spi_narrow_away(a, 30u, &flags);
    return sp_flags_status(flags);
}

/* (sin, cos) of one angle with s^2 + c^2 <= (2^30 + 4)^2 (sp_sincos_q24's
 * are within 1.05 LSB each: s^2 + c^2 <= (2^30 + 2)^2). */
SPI_INLINE int unit_pair(sp_q30_t s, sp_q30_t c)
{
    return (uint64_t)((int64_t)s * s + (int64_t)c * c) <= (UINT64_C(1) << 60) + (UINT64_C(1) << 33) + 16u;
}

/* sp_body_rates_sc turning in yaw alone (roll and pitch rates and
 * accelerations 0): its rows with their zero terms left out (each exactly
 * 0, and every product of two rates is 0), the same sums rounded the same
 * way. Out of line: the general rows keep their registers. */
SPI_NOINLINE static sp_status_t body_rates_yaw(const sp_q30_t sc[6], const sp_q24_t rpy_rate[3],
                                               const sp_q24_t rpy_acc[3], sp_q24_t omega[3], sp_q24_t omega_dot[3])
{
    sp_flags_t flags = 0u;
    const int64_t half = INT64_C(1) << 29;
    const int64_t dy = rpy_rate[2];
    const int64_t ay = rpy_acc[2];
    sp_q30_t sp;
    sp_q30_t cpsr;
    sp_q30_t cpcr;

    if (!unit_pair(sc[0], sc[1]) || !unit_pair(sc[2], sc[3])) {
        return body_rates_wide(sc, rpy_rate, rpy_acc, omega, omega_dot);
    }
    sp = sc[2];
    cpsr = spi_mul30_up(sc[3], sc[0]);
    cpcr = spi_mul30_up(sc[3], sc[1]);
    omega[0] = spi_narrow_floor(half - dy * sp, 30u, &flags);
    omega[1] = spi_narrow_floor(dy * cpsr + half, 30u, &flags);
    omega[2] = spi_narrow_floor(dy * cpcr + half, 30u, &flags);
    omega_dot[0] = spi_narrow_floor(half - ay * sp, 30u, &flags);
    omega_dot[1] = spi_narrow_floor(ay * cpsr + half, 30u, &flags);
    omega_dot[2] = spi_narrow_floor(ay * cpcr + half, 30u, &flags);
    return sp_flags_status(flags);
}

/* sp_body_rates_sc's rows for rates and accelerations not all 0 and not
 * in yaw alone. */
SPI_NOINLINE static sp_status_t body_rates_rows(const sp_q30_t sc[6], const sp_q24_t rpy_rate[3],
                                                const sp_q24_t rpy_acc[3], sp_q24_t omega[3], sp_q24_t omega_dot[3])
{
    sp_flags_t flags = 0u;
    sp_q30_t sr;
    sp_q30_t cr;
    sp_q30_t sp;
    sp_q30_t cp;
    sp_q30_t cpsr;
    sp_q30_t cpcr;
    sp_q30_t spsr;
    sp_q30_t spcr;
    int64_t dr;
    int64_t dp;
    int64_t dy;
    sp_q24_t dp_dr;
    sp_q24_t dy_dp;
    sp_q24_t dy_dr;
    const int64_t half = INT64_C(1) << 29;

    sr = sc[0];
    cr = sc[1];
    sp = sc[2];
    cp = sc[3];
    if (!unit_pair(sr, cr) || !unit_pair(sp, cp)) {
        return body_rates_wide(sc, rpy_rate, rpy_acc, omega, omega_dot);
    }
    /* Every row below is a sum of products x_k c_k with |x_k| <= 2^31 and
     * coefficient groups of norm at most K = 2^30 + 4 ((cr, sr), (cp, sp),
     * and (cp sr, sp sr, cp cr) whose squared norm is
     * sr^2 (cp^2 + sp^2) + cp^2 cr^2 <= K^2 (sr^2 + cr^2) / 2^60 <= K^2, up
     * to the products' rounding): by Cauchy-Schwarz each sum is below
     * (1 + sqrt 2 + sqrt 3) 2^31 K < 2^63. Each is rounded once (ties up),
     * saturated (SP_E_OVERFLOW) beyond int32. */
    cpsr = spi_mul30_up(cp, sr);
    cpcr = spi_mul30_up(cp, cr);
    dr = rpy_rate[0];
    dp = rpy_rate[1];
    dy = rpy_rate[2];
    spsr = spi_mul30_up(sp, sr);
    spcr = spi_mul30_up(sp, cr);

    /* eq (10); each subtracted product taken as a product with the
     * negated sine or cosine (exact: all are within 2^30 + 4 in
     * magnitude), the same exact sums in multiply-accumulates */
    omega[0] = spi_narrow_floor(dr * SP_Q30_ONE + dy * -sp + half, 30u, &flags);
    omega[1] = spi_narrow_floor(dp * cr + dy * cpsr + half, 30u, &flags);
    omega[2] = spi_narrow_floor(dy * cpcr + dp * -sr + half, 30u, &flags);

    /* d/dt of eq (10): the angle accelerations plus the products of rates. */
    dp_dr = spi_narrow_floor(dp * dr + (INT64_C(1) << 23), 24u, &flags); /* products below 2^62 */
    dy_dp = spi_narrow_floor(dy * dp + (INT64_C(1) << 23), 24u, &flags);
    dy_dr = spi_narrow_floor(dy * dr + (INT64_C(1) << 23), 24u, &flags);
    omega_dot[0] = spi_narrow_floor(
        (int64_t)rpy_acc[0] * SP_Q30_ONE + (int64_t)rpy_acc[2] * -sp + (int64_t)dy_dp * -cp + half, 30u, &flags);
    omega_dot[1] = spi_narrow_floor((int64_t)rpy_acc[1] * cr + (int64_t)dp_dr * -sr + (int64_t)rpy_acc[2] * cpsr +
                                        (int64_t)dy_dp * -spsr + (int64_t)dy_dr * cpcr + half,
                                    30u, &flags);
    omega_dot[2] = spi_narrow_floor((int64_t)rpy_acc[2] * cpcr + (int64_t)rpy_acc[1] * -sr + (int64_t)dp_dr * -cr +
                                        (int64_t)dy_dp * -spcr + (int64_t)dy_dr * -cpsr + half,
                                    30u, &flags);
    return sp_flags_status(flags);
}

sp_status_t sp_body_rates_sc(const sp_q30_t sc[6], const sp_q24_t rpy_rate[3], const sp_q24_t rpy_acc[3],
                             sp_q24_t omega[3], sp_q24_t omega_dot[3])
{
    if (sc == NULL || rpy_rate == NULL || rpy_acc == NULL || omega == NULL || omega_dot == NULL) {
        return SP_E_ARG;
    }
    if ((rpy_rate[0] | rpy_rate[1] | rpy_rate[2] | rpy_acc[0] | rpy_acc[1] | rpy_acc[2]) == 0) {
        /* no turning (a translation, rest): every product below is 0 and
         * each row rounds to 0 exactly, for any sc */
        for (unsigned k = 0u; k < 3u; ++k) {
            omega[k] = 0;
            omega_dot[k] = 0;
        }
        return SP_OK;
    }
    if ((rpy_rate[0] | rpy_rate[1] | rpy_acc[0] | rpy_acc[1]) != 0) {
        return body_rates_rows(sc, rpy_rate, rpy_acc, omega, omega_dot);
    }
    if (level(sc)) {
        /* turning in yaw alone about the vertical (roll = pitch = 0):
         * body_rates_yaw's rows with sp = cp sr = 0 and cp cr = 2^30, each
         * exact: w = yaw rate e_z, dw/dt = yaw acceleration e_z */
        omega[0] = 0;
        omega[1] = 0;
        omega[2] = rpy_rate[2];
        omega_dot[0] = 0;
        omega_dot[1] = 0;
        omega_dot[2] = rpy_acc[2];
        return SP_OK;
    }
    return body_rates_yaw(sc, rpy_rate, rpy_acc, omega, omega_dot);
}

/* sp_leg_rates' legs for any w (|w_c| up to 2^31): each step rounded and
 * saturated on its own (the path for |w_c| >= 64 rad/s). */
SPI_COLD static void leg_rates_wide(const sp_ik_t *ik, const sp_q24_t vel[3], const sp_q24_t w[3],
                                    sp_q24_t rate[SP_LEGS], sp_flags_t *flags)
{
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        sp_q24_t v[3];
        /* joint velocity v + w x r, Q24 x Q24 -> Q24; |w_c| < 2^31 (a
         * saturated w_c is at most 2^31 - 1 or exactly -2^31, and one product of a
         * difference is then below 2^62 in magnitude): below 2^63 */
        v[0] = spi_add(vel[0], spi_sat(spi_round_away((int64_t)w[1] * r[2] - (int64_t)w[2] * r[1], 24u), flags), flags);
        v[1] = spi_add(vel[1], spi_sat(spi_round_away((int64_t)w[2] * r[0] - (int64_t)w[0] * r[2], 24u), flags), flags);
        v[2] = spi_add(vel[2], spi_sat(spi_round_away((int64_t)w[0] * r[1] - (int64_t)w[1] * r[0], 24u), flags), flags);
        /* u . v with |u_c| <= 2^30: the exact sum is below 3 * 2^61 */
        rate[i] = spi_sat(spi_round_away((int64_t)ik->unit[i][0] * v[0] + (int64_t)ik->unit[i][1] * v[1] +
                                             (int64_t)ik->unit[i][2] * v[2],
                                         30u),
                          flags);
    }
}

sp_status_t sp_leg_rates(const sp_ik_t *ik, const sp_q24_t vel[3], const sp_q24_t rpy_rate[3], sp_q24_t rate[SP_LEGS])
{
    sp_flags_t flags = 0u;
    int64_t a[3];
    sp_q24_t w[3];
    int64_t vb[3];
    unsigned i;
    unsigned c;

    if (ik == NULL || vel == NULL || rpy_rate == NULL || rate == NULL) {
        return SP_E_ARG;
    }
    /* Angular velocity in the base frame for Z-Y-X angles:
     * w = roll_rate * (R e_x) + pitch_rate * (Rz e_y) + yaw_rate * e_z,
     * and R e_x is row 0 of T, Rz e_y = (-sin yaw, cos yaw, 0). Two Q24 x
     * Q30 products: below 2^63. */
    a[0] = (int64_t)rpy_rate[0] * ik->rot.t[0][0] - (int64_t)rpy_rate[1] * ik->sc[4] + (INT64_C(1) << 29);
    a[1] = (int64_t)rpy_rate[0] * ik->rot.t[0][1] + (int64_t)rpy_rate[1] * ik->sc[5] + (INT64_C(1) << 29);
    a[2] = (int64_t)rpy_rate[0] * ik->rot.t[0][2] + (int64_t)rpy_rate[2] * SP_Q30_ONE + (INT64_C(1) << 29);
    /* w_c = a_c / 2^30 is in [-2^30, 2^30) (64 rad/s) exactly when a_c's
     * high word is in [-2^28, 2^28): all three in one test */
    if (((((uint32_t)((uint64_t)a[0] >> 32) + (UINT32_C(1) << 28)) |
          ((uint32_t)((uint64_t)a[1] >> 32) + (UINT32_C(1) << 28)) |
          ((uint32_t)((uint64_t)a[2] >> 32) + (UINT32_C(1) << 28))) >>
         29) != 0u) {
        for (c = 0u; c < 3u; ++c) {
            w[c] = spi_narrow_floor(a[c], 30u, &flags);
        }
        leg_rates_wide(ik, vel, w, rate, &flags);
        return sp_flags_status(flags);
    }
    for (c = 0u; c < 3u; ++c) {
        w[c] = (int32_t)(a[c] >> 30);                                      /* exact, in range */
        vb[c] = (int64_t)vel[c] * (INT64_C(1) << 24) + (INT64_C(1) << 23); /* |vb| < 2^55 + 2^23 */
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        const sp_q30_t *u = ik->unit[i];
        sp_q24_t v0;
        sp_q24_t v1;
        sp_q24_t v2;
        /* joint velocity v + w x r (Q24 x Q24 -> Q24) in one sum, rounded
         * once: |w_c| <= 2^30, |r_c| <= 2^31, so w x r is at most 2^62
         * and the sum with v 2^24 below 2^63 */
        v0 = spi_narrow_floor(vb[0] + (int64_t)w[1] * r[2] - (int64_t)w[2] * r[1], 24u, &flags);
        v1 = spi_narrow_floor(vb[1] + (int64_t)w[2] * r[0] - (int64_t)w[0] * r[2], 24u, &flags);
        v2 = spi_narrow_floor(vb[2] + (int64_t)w[0] * r[1] - (int64_t)w[1] * r[0], 24u, &flags);
        /* u . v with |u_c| <= 2^30: the exact sum is below 3 * 2^61 */
        rate[i] = spi_narrow_floor((int64_t)u[0] * v0 + (int64_t)u[1] * v1 + (int64_t)u[2] * v2 + (INT64_C(1) << 29),
                                   30u, &flags);
    }
    return sp_flags_status(flags);
}

/* A moment entry r x u (Q54 with the rounding half) -> Q28: saturated
 * and flagged beyond int32, or, with near (arms below 2^26 in
 * magnitude, so the entry is below 2^31: spi_jacobian_near), the shift
 * alone, which gives the same value. */
SPI_INLINE int32_t moment_q28(int64_t x, int near, sp_flags_t *flags)
{
    return near ? (int32_t)(x >> 26) : spi_narrow_floor(x, 26u, flags);
}

/* sp_jacobian's rows; near: see moment_q28. */
SPI_INLINE void jacobian_rows(const sp_ik_t *ik, sp_jacobian_t *jac, int near, sp_flags_t *flags)
{
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        const int32_t r[3] = {ik->arm[i][0], ik->arm[i][1], ik->arm[i][2]};
        const int32_t u[3] = {ik->unit[i][0], ik->unit[i][1], ik->unit[i][2]};
        /* Q30 -> Q28 rounded (ties up): floor((floor(u/2) + 1) / 2) =
         * floor((u + 2) / 4), with no overflow for any int32 u */
        jac->j[i][0] = ((u[0] >> 1) + 1) >> 1;
        jac->j[i][1] = ((u[1] >> 1) + 1) >> 1;
        jac->j[i][2] = ((u[2] >> 1) + 1) >> 1;
        /* r x u: Q24 x Q30 = Q54 -> Q28; a difference of two int32 products
         * stays within 2^63 - 2^31 (only -2^31 * -2^31 reaches 2^62), and
         * the rounding half 2^25 keeps it below 2^63 */
        jac->j[i][3] = moment_q28((int64_t)r[1] * u[2] - (int64_t)r[2] * u[1] + (INT64_C(1) << 25), near, flags);
        jac->j[i][4] = moment_q28((int64_t)r[2] * u[0] - (int64_t)r[0] * u[2] + (INT64_C(1) << 25), near, flags);
        jac->j[i][5] = moment_q28((int64_t)r[0] * u[1] - (int64_t)r[1] * u[0] + (INT64_C(1) << 25), near, flags);
    }
}

sp_status_t sp_jacobian(const sp_ik_t *ik, sp_jacobian_t *jac)
{
    sp_flags_t flags = 0u;

    if (ik == NULL || jac == NULL) {
        return SP_E_ARG;
    }
    jacobian_rows(ik, jac, 0, &flags);
    return sp_flags_status(flags);
}

/* sp_jacobian for an ik whose arms are all below 2^26 (4 m) in magnitude
 * (a platform near: spi_joints_near): |r x u| <= |r| |u| < 2^56 (1 +
 * 2^-27), so no moment leaves int32 and each is the shift alone. */
void spi_jacobian_near(const sp_ik_t *ik, sp_jacobian_t *jac)
{
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        const int32_t r[3] = {ik->arm[i][0], ik->arm[i][1], ik->arm[i][2]};
        const int32_t u[3] = {ik->unit[i][0], ik->unit[i][1], ik->unit[i][2]};
        /* -r_c is exact (|r_c| < 2^26): each moment is one product plus
         * one product accumulated, the same exact sum as jacobian_rows' */
        const int32_t nr[3] = {-r[0], -r[1], -r[2]};
        /* Q30 -> Q28 rounded (ties up) as jacobian_rows, floor((u + 2) /
         * 4), in one addition: the IK's units are within 2^30 + 3 */
        jac->j[i][0] = (u[0] + 2) >> 2;
        jac->j[i][1] = (u[1] + 2) >> 2;
        jac->j[i][2] = (u[2] + 2) >> 2;
        jac->j[i][3] = (int32_t)(((int64_t)r[1] * u[2] + (int64_t)nr[2] * u[1] + (INT64_C(1) << 25)) >> 26);
        jac->j[i][4] = (int32_t)(((int64_t)r[2] * u[0] + (int64_t)nr[0] * u[2] + (INT64_C(1) << 25)) >> 26);
        jac->j[i][5] = (int32_t)(((int64_t)r[0] * u[1] + (int64_t)nr[1] * u[0] + (INT64_C(1) << 25)) >> 26);
    }
}

/* Every coordinate of six joints in [-2^(bits-1), 2^(bits-1)) of Q24:
 * c + 2^(bits-1) in [0, 2^bits), one unsigned shift each. */
static int joints_within(const sp_q24_t joint[SP_LEGS][3], unsigned bits)
{
    uint32_t out = 0u;
    unsigned i;
    unsigned c;

    for (i = 0u; i < SP_LEGS; ++i) {
        for (c = 0u; c < 3u; ++c) {
            out |= ((uint32_t)joint[i][c] + (UINT32_C(1) << (bits - 1u))) >> bits;
        }
    }
    return out == 0u;
}

int spi_joints_near(const sp_platform_t *platform)
{
    return joints_within(platform->platform_joint, 26u); /* a_c within 2 m */
}

int spi_legs_fit(const sp_platform_t *platform)
{
    return joints_within(platform->base_joint, 28u) && spi_joints_near(platform); /* b_c within 8 m */
}

/* lmin + d (1 + k) + zero, d = x - lmin, in int64; flags: saturation. */
static sp_q24_t sensor_map(sp_q24_t lmin, sp_q30_t k, int64_t zero, int64_t x, sp_flags_t *flags)
{
    int64_t d = x - (int64_t)lmin;
    return sp_sat32((int64_t)lmin + d + sp_mul64(d, k, 30u, flags) + zero, flags);
}

const sp_length_sensors_t *sp_length_sensors_in_use(const sp_length_sensors_t *sensors)
{
    const sp_length_sensors_t *used = NULL;
    unsigned i;
    for (i = 0u; (sensors != NULL) && (i < (unsigned)SP_LEGS); ++i) {
        if ((sensors->zero[i] != 0) || (sensors->scale[i] != 0) || (sensors->scale_inv[i] != 0)) {
            used = sensors;
        }
    }
    return used;
}

sp_status_t sp_length_from_sensor(const sp_platform_t *platform, const sp_length_sensors_t *sensors, unsigned leg,
                                  sp_q24_t reading, sp_q24_t *length)
{
    sp_flags_t flags = 0u;
    sp_status_t st = SP_E_ARG;
    if ((platform != NULL) && (length != NULL) && (leg < (unsigned)SP_LEGS)) {
        if (sensors == NULL) {
            *length = reading;
        } else {
            /* the zero first, then the gain: sp_length_to_sensor's steps reversed */
            *length = sensor_map(platform->leg_length_min, sensors->scale_inv[leg], 0,
                                 (int64_t)reading - (int64_t)sensors->zero[leg], &flags);
        }
        st = sp_flags_status(flags);
    }
    return st;
}

sp_status_t sp_length_to_sensor(const sp_platform_t *platform, const sp_length_sensors_t *sensors, unsigned leg,
                                sp_q24_t length, sp_q24_t *reading)
{
    sp_flags_t flags = 0u;
    sp_status_t st = SP_E_ARG;
    if ((platform != NULL) && (reading != NULL) && (leg < (unsigned)SP_LEGS)) {
        if (sensors == NULL) {
            *reading = length;
        } else {
            *reading = sensor_map(platform->leg_length_min, sensors->scale[leg], (int64_t)sensors->zero[leg],
                                  (int64_t)length, &flags);
        }
        st = sp_flags_status(flags);
    }
    return st;
}
