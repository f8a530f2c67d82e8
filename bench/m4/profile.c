/* SPDX-License-Identifier: Apache-2.0 */
/*
 * profile.c - a window of the controller scenario for an instruction
 * profile under QEMU's execution trace (bench/m4/profile.sh): which
 * functions the controller tick spends its instructions in. The scenario
 * runs untraced-in-effect up to the first RUNNING tick; profile_begin()
 * marks where the count starts (profile.sh ignores everything before its
 * first execution), then PROFILE_TICKS ticks in RUNNING (the paper's
 * surge), or, in the force scenario (PROFILE_MOTION M4_MOTION_FORCE),
 * PROFILE_TICKS ticks from the FORCE command's tick on; with
 * PROFILE_START_CMD, from the first tick with that command (the ENGAGE
 * tick: sp_m4_profile_engage; the RUN_TRIG tick: sp_m4_profile_trig; the
 * STREAM tick: sp_m4_profile_stream_start). Each counted tick's
 * sp_ctrl_step call sits between profile_tick() and profile_tick_end(),
 * so that profile.sh can keep only the highest ticks (PROFILE_ABOVE). Not
 * a measurement program: icount.c gives the figures.
 */
#include "m4_vectors.h"
#include "sp_mps2.h"

#include "sp/control/controller.h"

#ifndef PROFILE_TICKS
#define PROFILE_TICKS 300u
#endif
#ifndef PROFILE_MOTION
#define PROFILE_MOTION M4_MOTION_SURGE /* or M4_MOTION_YAW, M4_MOTION_STREAM, M4_MOTION_FORCE */
#endif

static m4_scenario_t scenario;

/* The marker: its first execution starts the count in profile.sh. */
__attribute__((noinline, noipa)) void profile_begin(void);
__attribute__((noinline, noipa)) void profile_begin(void)
{
    __asm__ volatile("nop");
}

/* The tick's markers: the controller's step runs between them. */
__attribute__((noinline, noipa)) void profile_tick(void);
__attribute__((noinline, noipa)) void profile_tick(void)
{
    __asm__ volatile("nop");
}

__attribute__((noinline, noipa)) void profile_tick_end(void);
__attribute__((noinline, noipa)) void profile_tick_end(void)
{
    __asm__ volatile("nop");
}

int main(void)
{
    uint32_t n = 0u;
    int started = 0;
#ifdef PROFILE_FRAMES
    m4_scenario_frames = PROFILE_FRAMES; /* 1: a tool tip, 2: turned tool and work frames */
#endif
    if (m4_scenario_init(&scenario, &sp_platform_default, PROFILE_MOTION) != SP_OK) {
        return 1;
    }
    while (n < PROFILE_TICKS && m4_scenario_prepare(&scenario)) {
#ifdef PROFILE_START_CMD
        int start = scenario.in.cmd.type == PROFILE_START_CMD;
#else
        int start = (scenario.motion == M4_MOTION_FORCE) ? scenario.in.cmd.type == SP_CMD_FORCE
                                                         : scenario.out.state == SP_STATE_RUNNING;
#endif
        if (!started && start) {
            profile_begin();
            started = 1;
        }
        if (started) {
            profile_tick();
        }
        (void)sp_ctrl_step(&scenario.cfg, &scenario.ctrl, &scenario.in, &scenario.out);
        if (started) {
            profile_tick_end();
        }
        m4_scenario_finish(&scenario);
        if (started) {
            ++n;
        }
    }
    return started ? 0 : 1;
}
