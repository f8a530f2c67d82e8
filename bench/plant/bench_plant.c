/* SPDX-License-Identifier: Apache-2.0 */
/*
 * bench_plant - speed of the plant simulator alone (no bus): simulated
 * seconds per wall-clock second in hydraulic mode, six cylinders under
 * their drives in ACTIVE, following a 0.5 Hz cosine that moves all six
 * pose axes by 30-50 mm / rad from rest (setpoints from the plant's own
 * double-precision leg lengths, rates by central difference, forces for
 * gravity and the translational inertia; the rotational inertia is left to
 * the position loop). 1 ms cycles with the
 * default 10 RK4 substeps each. Prints the best of several runs (the
 * machine is shared) and the tracking error as a sanity check. Not a test.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "hs/kin.h"
#include "hs/plant.h"

#define CYCLES 10000 /* 10 simulated seconds per run */
#define RUNS 5
#define DT 1e-3
#define TWO_PI 6.283185307179586

static double clock_s(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* All six axes: offset_k = A_k (1 - cos(2 pi 0.5 t)) with alternating signs
 * (starts at rest); acc: the translational acceleration. */
static void pose_at(const hs_params_t *p, double t, double pose[6], double acc[3])
{
    static const double amp[6] = {0.05, 0.04, 0.03, 0.03, 0.03, 0.04};
    double w = TWO_PI * 0.5;
    for (int k = 0; k < 6; ++k) {
        double sign = (k % 2) ? -1.0 : 1.0;
        pose[k] = p->home[k] + sign * amp[k] * (1.0 - cos(w * t));
        if (k < 3) {
            acc[k] = sign * amp[k] * w * w * cos(w * t);
        }
    }
}

/* Setpoints of all cycles, computed before timing. */
static double sp_len[CYCLES][HS_LEGS];
static double sp_vel[CYCLES][HS_LEGS];
static double sp_force[CYCLES][HS_LEGS];
static hs_plant_t plant;

int main(void)
{
    hs_params_t p;
    double best = 1e30, best_cpu = 1e30, err_max = 0.0;
    if (hs_params_default(&p) != HS_OK) {
        fprintf(stderr, "bench_plant: default parameters rejected\n");
        return 1;
    }
    for (int n = 0; n < CYCLES; ++n) {
        double t = n * DT, pose[6], acc[3], lp[HS_LEGS], lm[HS_LEGS], fext[3];
        pose_at(&p, t + 1e-5, pose, acc);
        hs_leg_lengths(&p, pose, lp);
        pose_at(&p, t - 1e-5, pose, acc);
        hs_leg_lengths(&p, pose, lm);
        pose_at(&p, t, pose, acc);
        hs_leg_lengths(&p, pose, sp_len[n]);
        for (int k = 0; k < 3; ++k) {
            fext[k] = -p.mass * acc[k]; /* d'Alembert: translational inertia only */
        }
        hs_static_forces(&p, pose, fext, NULL, sp_force[n]);
        for (int i = 0; i < HS_LEGS; ++i) {
            sp_vel[n][i] = (lp[i] - lm[i]) / 2e-5;
        }
    }
    for (int r = 0; r < RUNS; ++r) {
        double t0, t1, c0, c1;
        hs_state_t st;
        if (hs_plant_init(&plant, &p, p.home) != HS_OK) {
            fprintf(stderr, "bench_plant: init failed\n");
            return 1;
        }
        t0 = clock_s(CLOCK_MONOTONIC);
        c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
        for (int n = 0; n < CYCLES; ++n) {
            for (int i = 0; i < HS_LEGS; ++i) {
                hs_plant_set_setpoint(&plant, i, sp_len[n][i], sp_vel[n][i], sp_force[n][i], HS_REQ_ACTIVE);
            }
            if (hs_plant_step(&plant, DT) != HS_OK) {
                fprintf(stderr, "bench_plant: step failed\n");
                return 1;
            }
            if (r == 0 && n + 1 < CYCLES) {
                hs_plant_state(&plant, &st);
                for (int i = 0; i < HS_LEGS; ++i) {
                    /* the setpoint of cycle n+1 is where the leg should be now */
                    double e = fabs(st.length[i] - sp_len[n + 1][i]);
                    err_max = (e > err_max) ? e : err_max;
                }
            }
        }
        t1 = clock_s(CLOCK_MONOTONIC);
        c1 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
        if (t1 - t0 < best) {
            best = t1 - t0;
        }
        if (c1 - c0 < best_cpu) {
            best_cpu = c1 - c0;
        }
        for (int i = 0; i < HS_LEGS; ++i) {
            hs_feedback_t fb;
            hs_plant_feedback(&plant, i, &fb);
            if (fb.state != HS_DRIVE_ACTIVE) {
                fprintf(stderr, "bench_plant: drive %d left ACTIVE (state %d, faults 0x%02x)\n", i + 1, (int)fb.state,
                        (unsigned)fb.faults);
                return 1;
            }
        }
    }
    printf("plant (hydraulic, 6 cylinders + drives, %u RK4 substeps per 1 ms cycle):\n", (unsigned)p.substeps);
    printf("  %.1f simulated s per wall s (best of %d runs of %.0f s; %.2f us per cycle)\n", CYCLES * DT / best, RUNS,
           CYCLES * DT, best / CYCLES * 1e6);
    printf("  %.1f simulated s per CPU s (the same runs timed by process CPU time; the\n"
           "  wall figure is lower when other processes share the cores)\n",
           CYCLES * DT / best_cpu);
    printf("  largest leg tracking error over the run: %.1f um\n", err_max * 1e6);
    return 0;
}
