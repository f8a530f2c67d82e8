/* SPDX-License-Identifier: Apache-2.0 */
/*
 * golden.c - golden vectors of the portable core, built twice from this one
 * source: for the host, and for a Cortex-M4 (QEMU mps2-an386, semihosting).
 * Both builds print every output of the core as hex words, one record per
 * line, then an FNV-1a 64-bit hash of all the lines; tests/m4 runs both and
 * requires the two outputs to be identical byte for byte.
 *
 * Inputs (integer pseudo-random generator, fixed seed; no floating point):
 *   - the platform (sp_platform_default) itself;
 *   - M4_POSES random motions in the box of issue 7 around home, through
 *     sp_inverse_kinematics, sp_body_rates, sp_leg_rates, sp_inverse_dynamics,
 *     sp_check_legs and sp_forward_kinematics (warm start from a guess
 *     +-1 mm, +-1 mrad away); icount.c counts instructions on the same ones;
 *   - M4_PRIM_CASES random arguments of each fixed-point primitive;
 *   - three controller scenarios of m4_vectors.h (the plant follows the
 *     setpoints with a tracking error, m4_scenario.c), every
 *     tick's output, the wrench estimate and force control's included: the
 *     paper's surge (ENGAGE, the 90 mm 0.5 Hz surge, PARK), STREAM (a new
 *     target every tick in all six axes) and force control (TARE, FORCE
 *     2 kN on the sensor, a slide while holding, PARK).
 * The program also checks that each run did what it should (every IK and
 * inverse dynamics succeeded, FK converged, each scenario went through
 * ENGAGING, READY, RUNNING, PARKING back to IDLE without a fault, force
 * control held contact): exit status 0 only then, so that two identical but
 * broken outputs cannot pass.
 */
#include "m4_io.h"
#include "m4_vectors.h"

#include "sp/control/controller.h"
#include "sp/model/dynamics.h"
#include "sp/force/force.h"
#include "sp/model/kinematics.h"

#define M4_POSES 2000u
#define M4_PRIM_CASES 1000u

/* sp_platform_t is printed as an array of int32 words. */
typedef char m4_platform_is_words[(sizeof(sp_platform_t) % sizeof(int32_t) == 0u) ? 1 : -1];

static void record(const char *tag, uint32_t index, int32_t status)
{
    m4_out_str(tag);
    m4_out_hex(index);
    m4_out_hex((uint32_t)status);
}

/* An int32 spread over all magnitudes: bit width uniform in 0..31. */
static int32_t logscale(m4_rng_t *rng)
{
    uint32_t r = m4_rng_next(rng);
    uint32_t bits = r % 32u;
    int32_t v = (int32_t)(m4_rng_next(rng) & ((UINT32_C(1) << bits) - 1u));
    return ((r & 0x80000000u) != 0u) ? -v : v;
}

static int32_t any_int(m4_rng_t *rng)
{
    return ((m4_rng_next(rng) & 1u) != 0u) ? (int32_t)m4_rng_next(rng) : logscale(rng);
}

static void primitives(m4_rng_t *rng)
{
    uint32_t n;
    for (n = 0u; n < M4_PRIM_CASES; ++n) {
        int32_t a = any_int(rng);
        int32_t b = any_int(rng);
        int32_t c = any_int(rng);
        int32_t v3a[3];
        int32_t v3b[3];
        int64_t wide = (int64_t)a * 16777216 + b;
        unsigned shift = m4_rng_next(rng) % 63u;
        sp_flags_t fl[12] = {0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};
        int32_t w[24];
        int64_t m64;
        int64_t d64;
        unsigned k;

        for (k = 0u; k < 3u; ++k) {
            v3a[k] = any_int(rng);
            v3b[k] = any_int(rng);
        }
        w[0] = sp_add(a, b, &fl[0]);
        w[1] = sp_sub(a, b, &fl[0]);
        w[2] = sp_neg(a, &fl[1]);
        w[3] = sp_abs(a, &fl[1]);
        w[4] = sp_mul_q24(a, b, &fl[2]);
        w[5] = sp_mul_q30(a, b, &fl[3]);
        w[6] = sp_mul(a, b, shift, &fl[4]);
        w[7] = sp_div_q24(a, b, &fl[5]);
        w[8] = sp_div(wide, c, shift, &fl[6]);
        w[9] = sp_sqrt_q24(a, &fl[7]);
        w[10] = (int32_t)sp_isqrt64((uint64_t)wide * (uint64_t)(uint32_t)c);
        sp_sincos_q24(a, &w[11], &w[12]);
        w[13] = sp_dot3(v3a, v3b, shift, &fl[8]);
        m64 = sp_mul64(wide * 97, c, shift, &fl[9]);
        d64 = sp_div64(wide * 89, c, shift, &fl[10]);
        w[14] = (int32_t)(uint32_t)((uint64_t)m64 >> 32);
        w[15] = (int32_t)(uint32_t)(uint64_t)m64;
        w[16] = (int32_t)(uint32_t)((uint64_t)d64 >> 32);
        w[17] = (int32_t)(uint32_t)(uint64_t)d64;
        w[18] = (int32_t)(uint32_t)((uint64_t)sp_rshift_round(wide * 31, shift) >> 32);
        w[19] = sp_narrow(wide * 31, shift, &fl[11]);
        w[20] = (int32_t)(fl[0] | (fl[1] << 2) | (fl[2] << 4) | (fl[3] << 6) | (fl[4] << 8) | (fl[5] << 10));
        w[21] = (int32_t)(fl[6] | (fl[7] << 2) | (fl[8] << 4) | (fl[9] << 6) | (fl[10] << 8) | (fl[11] << 10));
        w[22] = (int32_t)sp_flags_status(fl[6] | fl[7]);
        w[23] = (int32_t)shift;
        record("prim", n, 0);
        m4_out_hex((uint32_t)a);
        m4_out_hex((uint32_t)b);
        m4_out_hex((uint32_t)c);
        m4_out_words(w, 24u);
        m4_out_nl();
    }
}

typedef struct {
    uint32_t ik_ok;
    uint32_t rates_ok;
    uint32_t id_ok;
    uint32_t fk_ok;
    uint32_t fk_iterations[9]; /* histogram, 8 = 8 or more */
} pose_summary_t;

static void poses(m4_rng_t *rng, pose_summary_t *sum)
{
    const sp_platform_t *p = &sp_platform_default;
    sp_fk_options_t opt;
    uint32_t n;

    sp_fk_default_options(&opt);
    for (n = 0u; n < M4_POSES; ++n) {
        static sp_motion_t m;
        static sp_ik_t ik;
        static sp_ik_t fk_ik;
        sp_q24_t rate[SP_LEGS];
        sp_q24_t omega[3];
        sp_q24_t omega_dot[3];
        sp_q8_t force[SP_LEGS];
        sp_pose_t guess;
        sp_pose_t pose;
        sp_fk_info_t info;
        sp_leg_limits_t lim;
        sp_status_t st;

        m4_random_motion(rng, p, &m);
        m4_nearby_pose(rng, &m.pose, &guess);
        record("motion", n, 0);
        m4_out_words(m.pose.pos, 3u);
        m4_out_words(m.pose.rpy, 3u);
        m4_out_words(m.vel, 3u);
        m4_out_words(m.rpy_rate, 3u);
        m4_out_words(m.acc, 3u);
        m4_out_words(m.rpy_acc, 3u);
        m4_out_nl();

        st = sp_inverse_kinematics(p, &m.pose, &ik);
        sum->ik_ok += (st == SP_OK) ? 1u : 0u;
        record("ik", n, (int32_t)st);
        m4_out_words(&ik.rot.t[0][0], 9u);
        m4_out_words(&ik.arm[0][0], 3u * SP_LEGS);
        m4_out_words(&ik.leg[0][0], 3u * SP_LEGS);
        m4_out_words(ik.length, SP_LEGS);
        m4_out_words(&ik.unit[0][0], 3u * SP_LEGS);
        m4_out_nl();

        st = sp_body_rates(m.pose.rpy, m.rpy_rate, m.rpy_acc, omega, omega_dot);
        record("body", n, (int32_t)st);
        m4_out_words(omega, 3u);
        m4_out_words(omega_dot, 3u);
        m4_out_nl();

        st = sp_leg_rates(&ik, m.vel, m.rpy_rate, rate);
        sum->rates_ok += (st == SP_OK) ? 1u : 0u;
        record("rates", n, (int32_t)st);
        m4_out_words(rate, SP_LEGS);
        m4_out_nl();

        st = sp_inverse_dynamics(p, &m, &ik, NULL, force);
        sum->id_ok += (st == SP_OK) ? 1u : 0u;
        record("id", n, (int32_t)st);
        m4_out_words(force, SP_LEGS);
        m4_out_nl();

        st = sp_check_legs(p, ik.length, rate, force, &lim);
        record("limits", n, (int32_t)st);
        m4_out_hex(lim.too_short);
        m4_out_hex(lim.too_long);
        m4_out_hex(lim.too_fast);
        m4_out_hex(lim.over_force);
        m4_out_nl();

        st = sp_forward_kinematics(p, ik.length, &guess, &opt, &pose, &fk_ik, &info);
        sum->fk_ok += (st == SP_OK) ? 1u : 0u;
        sum->fk_iterations[info.iterations < 8u ? info.iterations : 8u]++;
        record("fk", n, (int32_t)st);
        m4_out_hex(info.iterations);
        m4_out_hex((uint32_t)info.residual);
        m4_out_words(guess.pos, 3u);
        m4_out_words(guess.rpy, 3u);
        m4_out_words(pose.pos, 3u);
        m4_out_words(pose.rpy, 3u);
        m4_out_words(fk_ik.length, SP_LEGS);
        m4_out_nl();
    }
}

/* What a scenario's run showed, for the checks. */
typedef struct {
    uint32_t force_modes; /* bit m set once force_mode m was output */
    uint32_t contact_ticks;
    uint32_t wrench_valid_ticks;
} run_seen_t;

static void controller(m4_scenario_t *s, sp_status_t init_status, run_seen_t *seen)
{
    uint32_t n = 0u;
    record("ctrl_init", 0u, (int32_t)init_status);
    m4_out_nl();
    while (m4_scenario_prepare(s)) {
        const sp_ctrl_output_t *o = &s->out;
        sp_status_t st = sp_ctrl_step(&s->cfg, &s->ctrl, &s->in, &s->out);
        unsigned i;
        record("tick", n, (int32_t)st);
        m4_out_hex((uint32_t)s->in.cmd.type);
        for (i = 0u; i < SP_LEGS; ++i) {
            m4_out_hex((uint32_t)o->setpoint[i].length);
            m4_out_hex((uint32_t)o->setpoint[i].velocity);
            m4_out_hex((uint32_t)o->setpoint[i].force);
        }
        m4_out_hex((uint32_t)o->drive_mode);
        m4_out_hex((uint32_t)o->state);
        m4_out_hex(o->faults);
        m4_out_hex(o->tick);
        m4_out_hex(o->fk_iterations);
        m4_out_hex(o->estimate_valid);
        m4_out_hex(o->cmd_rejected);
        m4_out_words(o->estimate.pos, 3u);
        m4_out_words(o->estimate.rpy, 3u);
        m4_out_words(o->reference.pose.pos, 3u);
        m4_out_words(o->reference.pose.rpy, 3u);
        m4_out_words(o->reference.vel, 3u);
        m4_out_words(o->reference.rpy_rate, 3u);
        m4_out_words(o->reference.acc, 3u);
        m4_out_words(o->reference.rpy_acc, 3u);
        m4_out_hex(o->wrench_valid);
        m4_out_words(o->wrench, 6u);
        m4_out_hex(o->force_mode);
        m4_out_hex(o->contact);
        m4_out_words(o->force_target, 6u);
        m4_out_words(o->force_wrench, 6u);
        m4_out_nl();
        if (o->force_mode < 32u) {
            seen->force_modes |= UINT32_C(1) << o->force_mode;
        }
        seen->contact_ticks += o->contact;
        seen->wrench_valid_ticks += o->wrench_valid;
        m4_scenario_finish(s);
        ++n;
    }
}

static int check(int ok, const char *what, int *failures)
{
    if (!ok) {
        m4_out_str("check failed: ");
        m4_out_str(what);
        m4_out_nl();
        ++*failures;
    }
    return ok;
}

/* One scenario from init to its end, its summary line, and its checks. */
static void scenario_run(m4_scenario_t *s, uint8_t motion, const char *name, int *failures)
{
    static const uint32_t want_states = (UINT32_C(1) << SP_STATE_IDLE) | (UINT32_C(1) << SP_STATE_ENGAGING) |
                                        (UINT32_C(1) << SP_STATE_READY) | (UINT32_C(1) << SP_STATE_RUNNING) |
                                        (UINT32_C(1) << SP_STATE_PARKING);
    run_seen_t seen = {0u, 0u, 0u};
    sp_status_t init_status = m4_scenario_init(s, &sp_platform_default, motion);
    m4_out_str("scenario ");
    m4_out_str(name);
    m4_out_nl();
    controller(s, init_status, &seen);

    m4_out_str("summary ");
    m4_out_str(name);
    m4_out_str(" ticks ");
    m4_out_u32(s->ticks);
    m4_out_str(" running ");
    m4_out_u32(s->running_ticks);
    m4_out_str(" contact ");
    m4_out_u32(seen.contact_ticks);
    m4_out_str(" wrench_valid ");
    m4_out_u32(seen.wrench_valid_ticks);
    m4_out_str(" force_modes");
    m4_out_hex(seen.force_modes);
    m4_out_str(" final_state ");
    m4_out_str(sp_state_name(s->out.state));
    m4_out_str(" faults");
    m4_out_hex(s->out.faults);
    m4_out_nl();

    (void)check(init_status == SP_OK, "controller set-up", failures);
    (void)check(s->visited == want_states, "controller visits idle, engaging, ready, running, parking only", failures);
    (void)check(s->out.state == SP_STATE_IDLE && s->out.faults == 0u, "controller ends parked without a fault",
                failures);
    (void)check(seen.wrench_valid_ticks > 0u, "the wrench estimate runs", failures);
    if (motion == M4_MOTION_FORCE) {
        (void)check((seen.force_modes & (UINT32_C(1) << SP_FORCE_FORCE)) != 0u && seen.contact_ticks > 1000u,
                    "force control holds contact", failures);
    } else {
        (void)check(s->running_ticks >= M4_RUN_TICKS, "controller runs the motion", failures);
        (void)check(seen.force_modes == (UINT32_C(1) << SP_FORCE_OFF), "no force control outside its scenario",
                    failures);
    }
}

int main(void)
{
    static m4_scenario_t scenario;
    pose_summary_t sum = {0u, 0u, 0u, 0u, {0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u}};
    m4_rng_t rng;
    int failures = 0;
    unsigned k;

    m4_out_str("golden sp_core v2 poses");
    m4_out_hex(M4_POSES);
    m4_out_str(" primitives");
    m4_out_hex(M4_PRIM_CASES);
    m4_out_nl();
    m4_out_str("platform");
    m4_out_words((const int32_t *)(const void *)&sp_platform_default,
                 (unsigned)(sizeof(sp_platform_t) / sizeof(int32_t)));
    m4_out_nl();

    m4_rng_seed(&rng, M4_SEED);
    poses(&rng, &sum);
    primitives(&rng);
    scenario_run(&scenario, M4_MOTION_SURGE, "surge", &failures);
    scenario_run(&scenario, M4_MOTION_STREAM, "stream", &failures);
    scenario_run(&scenario, M4_MOTION_FORCE, "force", &failures);

    m4_out_str("summary ik_ok ");
    m4_out_u32(sum.ik_ok);
    m4_out_str(" rates_ok ");
    m4_out_u32(sum.rates_ok);
    m4_out_str(" id_ok ");
    m4_out_u32(sum.id_ok);
    m4_out_str(" fk_ok ");
    m4_out_u32(sum.fk_ok);
    m4_out_str(" fk_iterations");
    for (k = 0u; k < 9u; ++k) {
        m4_out_str(" ");
        m4_out_u32(k);
        m4_out_str(":");
        m4_out_u32(sum.fk_iterations[k]);
    }
    m4_out_nl();

    (void)check(sum.ik_ok == M4_POSES, "every inverse kinematics succeeds", &failures);
    (void)check(sum.rates_ok == M4_POSES, "every leg-rate computation succeeds", &failures);
    (void)check(sum.id_ok == M4_POSES, "every inverse dynamics succeeds", &failures);
    (void)check(sum.fk_ok == M4_POSES, "every warm-started forward kinematics converges", &failures);
    m4_out_str(failures == 0 ? "result ok" : "result FAILED");
    m4_out_nl();
    {
        uint64_t h = m4_out_hash();
        m4_out_str("fnv1a64 ");
        m4_out_hex64(h);
        m4_out_nl();
    }
    if (m4_out_flush() != 0) {
        return 2;
    }
    return failures == 0 ? 0 : 1;
}
