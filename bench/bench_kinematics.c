/* SPDX-License-Identifier: Apache-2.0 */
/*
 * bench_kinematics - host cost of the core's kinematics and dynamics on the
 * default platform (config/platform_default.json), over random poses and
 * motions around home, and the forward kinematics' iteration counts when
 * warm-started from the previous 1 kHz tick. Accuracy against the float64
 * model is printed by `stewart accuracy` (tools/stewart), which calls the
 * same core. Not a test: it asserts nothing.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>

#include "sp/control/controller.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"
#include "../tests/support/test_util.h"

#define N_POSES 4096
#define N_REPEAT 50

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static sp_motion_t motions[N_POSES];
static sp_ik_t iks[N_POSES];
static volatile int32_t sink;

static int32_t q24(double v)
{
    return (int32_t)lround(v * 16777216.0);
}

int main(void)
{
    const sp_platform_t *p = &sp_platform_default;
    uint64_t rng = 7;
    sp_fk_options_t opt;
    double t0;
    double t_ik;
    double t_id;
    double t_fk;
    uint32_t it_hist[10] = {0};
    unsigned fk_fail = 0;

    for (int n = 0; n < N_POSES; ++n) {
        sp_motion_t *m = &motions[n];
        for (int k = 0; k < 3; ++k) {
            double lim = (k == 2) ? 0.15 : 0.2;
            m->pose.pos[k] = p->home.pos[k] + q24(tu_uniform(&rng, -lim, lim));
            m->pose.rpy[k] = p->home.rpy[k] + q24(tu_uniform(&rng, -0.2618, 0.2618));
            m->vel[k] = q24(tu_uniform(&rng, -1, 1));
            m->rpy_rate[k] = q24(tu_uniform(&rng, -1, 1));
            m->acc[k] = q24(tu_uniform(&rng, -10, 10));
            m->rpy_acc[k] = q24(tu_uniform(&rng, -10, 10));
        }
    }

    t0 = now_ns();
    for (int r = 0; r < N_REPEAT; ++r) {
        for (int n = 0; n < N_POSES; ++n) {
            sink = (int32_t)sp_inverse_kinematics(p, &motions[n].pose, &iks[n]);
        }
    }
    t_ik = (now_ns() - t0) / (N_REPEAT * N_POSES);

    t0 = now_ns();
    for (int r = 0; r < N_REPEAT; ++r) {
        for (int n = 0; n < N_POSES; ++n) {
            sp_q8_t f[SP_LEGS];
            sink = (int32_t)sp_inverse_dynamics(p, &motions[n], &iks[n], NULL, f);
        }
    }
    t_id = (now_ns() - t0) / (N_REPEAT * N_POSES);

    /* FK warm-started from a pose one 1 kHz tick away (1 m/s, 1 rad/s). */
    sp_fk_default_options(&opt);
    t0 = now_ns();
    for (int r = 0; r < N_REPEAT; ++r) {
        for (int n = 0; n < N_POSES; ++n) {
            sp_pose_t guess = motions[n].pose;
            sp_pose_t out;
            sp_ik_t ik;
            sp_fk_info_t info;
            sp_status_t st;
            for (int k = 0; k < 3; ++k) {
                guess.pos[k] -= 16777 * ((n + k) % 3 - 1); /* -1, 0 or +1 mm */
                guess.rpy[k] -= 16777 * ((n + 2 * k) % 3 - 1);
            }
            st = sp_forward_kinematics(p, iks[n].length, &guess, &opt, &out, &ik, &info);
            if (r == 0) {
                if (st != SP_OK) {
                    ++fk_fail;
                }
                it_hist[info.iterations < 9u ? info.iterations : 9u]++;
            }
            sink = out.pos[0];
        }
    }
    t_fk = (now_ns() - t0) / (N_REPEAT * N_POSES);

    /* The whole controller tick, closed around a plant that follows its
     * setpoints a tick late with a +-42 um tracking error (the M4
     * scenarios' plant, bench/m4/m4_scenario.c): engage, the paper's
     * surge. */
    {
        static sp_ctrl_config_t cfg;
        static sp_ctrl_t ctrl;
        static sp_ctrl_input_t in;
        static sp_ctrl_output_t out;
        sp_ik_t park_ik;
        double worst = 0;
        double total = 0;
        int ticks = 0;
        sp_ctrl_default_config(&cfg, p);
        sp_ctrl_init(&ctrl, &cfg);
        sp_inverse_kinematics(p, &p->park, &park_ik);
        for (int i = 0; i < SP_LEGS; ++i) {
            in.drive[i].length = park_ik.length[i];
        }
        for (int n = 0; n < 16000; ++n) {
            double t1;
            double dt;
            for (int i = 0; i < SP_LEGS; ++i) {
                in.drive[i].fresh = 1u;
            }
            in.cmd.type = (n == 1) ? SP_CMD_ENGAGE : (n == 5000) ? SP_CMD_RUN_TRIG : SP_CMD_NONE;
            in.cmd.axis = SP_AXIS_X;
            in.cmd.amplitude = q24(0.09);
            in.cmd.frequency = q24(0.5);
            t1 = now_ns();
            sp_ctrl_step(&cfg, &ctrl, &in, &out);
            dt = now_ns() - t1;
            if (n > 100) {
                worst = dt > worst ? dt : worst;
                total += dt;
                ++ticks;
            }
            if (out.drive_mode == SP_DRIVE_ACTIVE) {
                for (int i = 0; i < SP_LEGS; ++i) {
                    int ph = (n + 67 * i) % 400;
                    in.drive[i].length = out.setpoint[i].length + 7 * (((ph < 200) ? ph : 400 - ph) - 100);
                }
            }
        }
        printf(
            "controller tick (engage + surge, +-42 um tracking error): mean %.0f ns, worst %.0f ns, final state %s\n",
            total / ticks, worst, sp_state_name(out.state));
    }

    printf("kinematics on the default platform, %d random poses and motions around home\n", N_POSES);
    printf("(+-0.2 m x/y, +-0.15 m z, +-15 deg, 1 m/s, 1 rad/s, 10 m/s^2, 10 rad/s^2)\n");
    printf("%-36s %10s\n", "function", "ns/call");
    printf("%-36s %10.1f\n", "sp_inverse_kinematics", t_ik);
    printf("%-36s %10.1f\n", "sp_inverse_dynamics (after IK)", t_id);
    printf("%-36s %10.1f\n", "sp_forward_kinematics (warm, 1 ms)", t_fk);
    printf("FK warm-start iterations:");
    for (int i = 0; i < 10; ++i) {
        if (it_hist[i] != 0u) {
            printf(" %d:%u", i, it_hist[i]);
        }
    }
    printf("  failures: %u\n", fk_fail);
    return 0;
}
