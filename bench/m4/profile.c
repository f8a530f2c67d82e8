/*
 * profile.c - a short run of the controller scenario (the first
 * PROFILE_TICKS ticks: ENGAGING, then the surge) for an instruction profile
 * under QEMU's execution trace (bench/m4/profile.sh): which functions and
 * which blocks the controller tick spends its instructions in. Not a
 * measurement program: icount.c gives the figures.
 */
#include "m4_vectors.h"
#include "sp_mps2.h"

#include "sp/controller.h"

#ifndef PROFILE_TICKS
#define PROFILE_TICKS 300u
#endif

static m4_scenario_t scenario;

int main(void)
{
    uint32_t n = 0u;
    if (m4_scenario_init(&scenario, &sp_platform_default) != SP_OK) {
        return 1;
    }
    while (n < PROFILE_TICKS && m4_scenario_prepare(&scenario)) {
        (void)sp_ctrl_step(&scenario.cfg, &scenario.ctrl, &scenario.in, &scenario.out);
        m4_scenario_finish(&scenario);
        ++n;
    }
    return 0;
}
