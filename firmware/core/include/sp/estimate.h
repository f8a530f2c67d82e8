/*
 * sp/estimate.h - the pose estimate: forward kinematics of the measured leg
 * lengths once per tick, warm-started from the previous estimate.
 *
 * Two ways to the same answer (the same convergence test, so the same
 * accuracy): chord steps with the factorisation of J^T that the inverse
 * dynamics left at the reference (no Jacobian, no factorisation, no IK at
 * the guess), when the estimate is near that reference; otherwise full
 * Newton (sp_forward_kinematics). The choice, the cache of the estimate's
 * lengths and sines and that factorisation live in sp_estimate_t.
 */
#ifndef SP_ESTIMATE_H
#define SP_ESTIMATE_H

#include "sp/kinematics.h"

/** Chord steps allowed before falling back to full Newton. */
#define SP_ESTIMATE_CHORD_STEPS 4u
/** The chord steps are tried when the estimate is within this distance of
 *  the reference on every axis: 10 mm, 10 mrad, Q24. */
#define SP_ESTIMATE_CHORD_NEAR ((sp_q24_t)167772)
/** Newton steps allowed for a cold start (no previous estimate). */
#define SP_ESTIMATE_COLD_STEPS 20u

/** The estimate and what the next tick's forward kinematics reuse. */
typedef struct {
    sp_pose_t pose;      /**< the estimate (the last valid one, or the park pose before the first) */
    uint8_t valid;       /**< 1 while pose is the forward kinematics of the last measured lengths */
    uint8_t cache_valid; /**< 1 while cache holds the lengths and sines of pose */
    sp_fk_cache_t cache; /**< pose's lengths and sines, for the chord steps */
    sp_lu6_t ref_lu;     /**< factorisation of J^T at the reference of the last tick (valid flag inside):
                               written by the inverse dynamics of the setpoints (sp_inverse_dynamics_lu),
                               invalidated by the controller whenever the reference has none */
} sp_estimate_t;

/** No estimate yet: pose = *park, nothing valid. */
void sp_estimate_init(sp_estimate_t *e, const sp_pose_t *park);

/**
 * One tick's estimate from the measured leg lengths (m, Q24). With a valid
 * estimate, a valid cache, a valid ref_lu and the estimate within
 * SP_ESTIMATE_CHORD_NEAR of `reference` (the pose ref_lu was factorised
 * at), first up to SP_ESTIMATE_CHORD_STEPS chord steps (sp_fk_chord);
 * otherwise, or when they fail, full Newton from the estimate with the
 * default options (sp_fk_default_options); with no valid estimate, a cold
 * start from platform->park with up to SP_ESTIMATE_COLD_STEPS steps and no
 * continuity check. *iterations (not NULL) gets the steps of the last
 * method tried. On SP_OK e->pose is the new estimate and e->cache its
 * lengths and sines; on an error (those of sp_forward_kinematics) the
 * estimate and the cache are invalid and e->pose keeps the last estimate.
 */
sp_status_t sp_estimate_step(const sp_platform_t *platform, sp_estimate_t *e, const sp_q24_t length[SP_LEGS],
                             const sp_pose_t *reference, uint32_t *iterations);

#endif /* SP_ESTIMATE_H */
