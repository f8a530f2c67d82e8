#include "sp/setpoint.h"

sp_status_t sp_setpoints_of(const sp_platform_t *platform, const sp_limits_t *lim, const sp_motion_t *ref,
                            int force_feedforward, sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu)
{
    sp_ik_t ik;
    sp_q24_t rate[SP_LEGS];
    sp_q8_t force[SP_LEGS];
    sp_status_t st;
    unsigned i;

    if (!sp_limits_in_workspace(lim, &ref->pose)) {
        return SP_E_RANGE;
    }
    st = sp_inverse_kinematics(platform, &ref->pose, &ik);
    if (st == SP_OK) {
        st = sp_leg_rates(&ik, ref->vel, ref->rpy_rate, rate);
    }
    if (st == SP_OK) {
        st = sp_inverse_dynamics_lu(platform, ref, &ik, NULL, force, lu);
    }
    if (st != SP_OK) {
        return st;
    }
    if (!sp_limits_setpoints_ok(lim, ik.length, rate, force)) {
        return SP_E_RANGE;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        sp[i].length = ik.length[i];
        sp[i].velocity = rate[i];
        sp[i].force = force_feedforward ? force[i] : 0;
    }
    return SP_OK;
}
