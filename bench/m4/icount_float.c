/* SPDX-License-Identifier: Apache-2.0 */
/*
 * icount_float.c - the side-by-side reference of icount.c: instructions
 * executed on a Cortex-M4F by a single-precision float implementation of
 * the same inverse kinematics and inverse dynamics (float_ref.c; FPU on,
 * hard-float ABI), on the same motions (the same generator and seed,
 * converted to float before the measurement). scripts/m4_bench.sh prints
 * the ratio fixed / float from the two programs' rows.
 * Exit status: 0, or 3 if the counter's calibration failed.
 */
#include "float_ref.h"
#include "m4_count.h"
#include "m4_io.h"
#include "m4_vectors.h"
#include "sp_mps2.h"

#define N_MOTIONS 2000u

static m4f_platform_t platform;
static m4f_motion_t motions[N_MOTIONS];
static m4f_ik_t ik;
static volatile float sink;

__attribute__((noipa)) static sp_status_t run_ik(const m4f_motion_t *m, m4f_ik_t *out)
{
    return m4f_inverse_kinematics(&platform, m->pos, m->rpy, out);
}

__attribute__((noipa)) static sp_status_t run_id(const m4f_motion_t *m, const m4f_ik_t *in, float *force)
{
    return m4f_inverse_dynamics(&platform, m, in, force);
}

__attribute__((noipa)) static void run_sincos(float a, float *s, float *c)
{
    m4f_sincos(a, s, c);
}

int main(void)
{
    m4_stat_t s_ik;
    m4_stat_t s_id;
    m4_stat_t s_sc;
    m4_rng_t rng;
    uint32_t failures = 0u;
    uint32_t n;

    m4_out_str("== Cortex-M4 instruction counts, single-precision float reference (FPv4-SP, hard-float ABI; "
               "compiled for " M4_OPTIMISATION ")");
    m4_out_nl();
    if (m4_count_init() != 0) {
        (void)m4_out_flush();
        return 3;
    }
    m4f_platform_from_fixed(&sp_platform_default, &platform);
    m4_rng_seed(&rng, M4_SEED);
    for (n = 0u; n < N_MOTIONS; ++n) {
        sp_motion_t m;
        sp_pose_t unused_guess;
        m4_random_motion(&rng, &sp_platform_default, &m);
        m4_nearby_pose(&rng, &m.pose, &unused_guess); /* keeps the sequence of icount.c */
        m4f_motion_from_fixed(&m, &motions[n]);
    }
    m4_stat_reset(&s_ik);
    m4_stat_reset(&s_id);
    m4_stat_reset(&s_sc);
    for (n = 0u; n < N_MOTIONS; ++n) {
        float force[SP_LEGS];
        float sn;
        float cs;
        sp_status_t st[2];
        uint32_t net;
        M4_MEASURE(net, st[0] = run_ik(&motions[n], &ik));
        m4_stat_add(&s_ik, net);
        M4_MEASURE(net, st[1] = run_id(&motions[n], &ik, force));
        m4_stat_add(&s_id, net);
        M4_MEASURE(net, run_sincos(motions[n].rpy[n % 3u] * 12.0f, &sn, &cs));
        m4_stat_add(&s_sc, net);
        failures += (st[0] != SP_OK ? 1u : 0u) + (st[1] != SP_OK ? 1u : 0u);
        sink = force[0] + sn + cs;
    }
    m4_stat_header();
    m4_stat_print("f_ik", "float inverse kinematics", &s_ik);
    m4_stat_print("f_id", "float inverse dynamics (after IK)", &s_id);
    m4_stat_print("f_sincos", "float sincos (|angle| <= pi)", &s_sc);
    if (failures != 0u) {
        m4_out_str("warning: ");
        m4_out_u32(failures);
        m4_out_str(" of these calls did not return SP_OK");
        m4_out_nl();
    }
    return m4_out_flush() == 0 ? 0 : 2;
}
