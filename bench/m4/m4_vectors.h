/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_vectors.h - the deterministic inputs shared by the golden-vector
 * program, the instruction-count benchmark and the float reference's test:
 * an integer pseudo-random generator (no floating point: identical on every
 * target), random poses and motions in the box of issue 7 around home, and
 * the controller scenario (ideal plant: every drive reaches its length
 * setpoint by the next tick).
 */
#ifndef M4_VECTORS_H
#define M4_VECTORS_H

#include <stdint.h>

#include "sp/control/controller.h"

/** Seed of every run (arbitrary, fixed). */
#define M4_SEED UINT64_C(0x5354455741525434)

/** splitmix64 state. */
typedef struct {
    uint64_t state;
} m4_rng_t;

void m4_rng_seed(m4_rng_t *rng, uint64_t seed);

/** Next 32 random bits (the upper half of a splitmix64 output). */
uint32_t m4_rng_next(m4_rng_t *rng);

/** Uniform integer in [-lim, lim], lim in [0, 2^30]. */
int32_t m4_rng_range(m4_rng_t *rng, int32_t lim);

/* The box of issue 7 around home, Q24. */
#define M4_BOX_XY INT32_C(3355443)    /* 0.2 m */
#define M4_BOX_Z INT32_C(2516582)     /* 0.15 m */
#define M4_BOX_ANGLE INT32_C(4392264) /* 15 deg = 0.2617994 rad */
#define M4_BOX_RATE INT32_C(16777216) /* 1 m/s, 1 rad/s */
#define M4_BOX_ACC INT32_C(167772160) /* 10 m/s^2, 10 rad/s^2 */
#define M4_NEAR_POS INT32_C(16777)    /* 1 mm: warm-start offset */
#define M4_NEAR_ANGLE INT32_C(16777)  /* 1 mrad */

/** A motion with pose uniform in home +- (0.2, 0.2, 0.15 m, 15 deg x 3),
 *  rates in +-1 m/s and +-1 rad/s, accelerations in +-10 m/s^2, rad/s^2. */
void m4_random_motion(m4_rng_t *rng, const sp_platform_t *platform, sp_motion_t *motion);

/** `pose` moved by up to +-1 mm and +-1 mrad per axis (a warm-start guess,
 *  about one 1 kHz tick away at 1 m/s and 1 rad/s). */
void m4_nearby_pose(m4_rng_t *rng, const sp_pose_t *pose, sp_pose_t *guess);

/* ---- controller scenario ------------------------------------------------ */

/** Ticks spent in RUNNING before PARK is commanded: the 2 s fade-in and
 *  one full 2 s period of the 0.5 Hz surge. */
#define M4_RUN_TICKS 4000u
/** Bound on the scenario's length (a stuck state machine ends the run). */
#define M4_MAX_TICKS 30000u
/** Ticks run after the platform is parked again. */
#define M4_TAIL_TICKS 10u

/** The scenario: IDLE at the park pose; ENGAGE; once READY, RUN_TRIG on x
 *  (the paper's surge: 90 mm, 0.5 Hz; or the motion set in `motion`); after
 *  M4_RUN_TICKS in RUNNING, PARK;
 *  once IDLE, M4_TAIL_TICKS more ticks. Feedback is fresh every tick, with
 *  the lengths the previous tick commanded (the park lengths until the
 *  drives are active). */
/** What the scenario runs once READY (m4_scenario_init's `motion`; the golden
 *  program runs SURGE, STREAM and FORCE; icount.c all four). */
#define M4_MOTION_SURGE 0u  /**< RUN_TRIG x, 90 mm, 0.5 Hz */
#define M4_MOTION_YAW 1u    /**< RUN_TRIG yaw, 0.09 rad, 0.5 Hz: every angle's sine changes */
#define M4_MOTION_STREAM 2u /**< STREAM with a fresh target every tick: the reachability test each tick */
#define M4_MOTION_FORCE                                                                                                \
    3u /**< force control on the force/torque sensor: TARE, FORCE 2 kN down on a
                                 1e6 N/m surface 2 mm under the tool, a 50 mm slide in x (MOVE_TO) while
                                 holding, PARK (which lets go first) */
#define M4_MOTION_FORCE_TWIN                                                                                           \
    4u /**< the force scenario in position control: the same commands and sensor, without
                                 the FORCE command (what force control adds is the difference) */

typedef struct {
    sp_ctrl_config_t cfg;
    sp_ctrl_t ctrl;
    sp_ctrl_input_t in;
    sp_ctrl_output_t out;
    uint32_t ticks;         /**< ticks run so far */
    uint32_t running_ticks; /**< ticks that ended in RUNNING */
    uint32_t tail;          /**< ticks run since the platform parked */
    uint32_t visited;       /**< bit s set once state s was output */
    uint8_t run_sent;
    uint8_t park_sent;
    uint8_t motion;       /**< M4_MOTION_* */
    uint8_t phase;        /**< M4_MOTION_FORCE: 0 engaging, 1 taring, 2 holding, 3 sliding and holding */
    uint32_t phase_ticks; /**< ticks since the phase began */
} m4_scenario_t;

/** The frames m4_scenario_init sets (issue 31's figures; 0 for the golden
 *  program): 0 identity; 1 a tool tip 0.35 m above o' and 0.15 m off its
 *  axis (the pivot); 2 that tool frame turned (0.05, -0.1, 0.2 rad) and a
 *  work frame tilted 20 deg about y at (0.2, 0.1, 0): every transform
 *  turns. */
extern uint8_t m4_scenario_frames;

/** Default config for `platform` and the scenario `motion` (M4_MOTION_*:
 *  FORCE reads the force/torque sensor), controller init, park-pose
 *  feedback. Returns the first failing status of the core calls. */
sp_status_t m4_scenario_init(m4_scenario_t *s, const sp_platform_t *platform, uint8_t motion);

/** Fills s->in for the next tick. Returns 0 once the scenario is over (no
 *  more ticks), else 1. */
int m4_scenario_prepare(m4_scenario_t *s);

/** Takes s->out of the tick just run: feedback for the next tick, state
 *  bookkeeping. */
void m4_scenario_finish(m4_scenario_t *s);

#endif /* M4_VECTORS_H */
