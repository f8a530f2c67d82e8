#include "sp/wrench.h"

#include "fixed_inline.h"

void sp_wrench_reset(sp_wrench_t *w)
{
    unsigned k;
    if (w == NULL) {
        return;
    }
    for (k = 0u; k < 6u; ++k) {
        w->wrench[k] = 0;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        w->model_force[k] = 0;
    }
    w->have_model = 0u;
    w->valid = 0u;
}

sp_status_t sp_wrench_alpha(sp_q24_t hz, uint32_t tick_us, sp_q30_t *alpha)
{
    sp_flags_t flags = 0u;
    int64_t wdt; /* 2 pi f dt, Q24 */
    if (alpha == NULL || hz <= 0 || tick_us == 0u || tick_us > 1000000u) {
        return SP_E_ARG;
    }
    /* 2 pi (Q24) x f (Q24) >> 24 = w (Q24, < 2^34), x dt */
    wdt = (((int64_t)SPI_Q24_TWO_PI * hz) >> 24) * (int64_t)tick_us / 1000000;
    if (wdt > (INT64_C(8) << 24)) {
        return SP_E_RANGE;
    }
    *alpha = sp_div(wdt, (int32_t)(wdt + (INT64_C(1) << 24)), 30u, &flags);
    return (flags == 0u) ? SP_OK : SP_E_RANGE;
}

/* |F_model - F| is clamped to 2^29 (2 MN in Q8, beyond any cylinder), so
 * each product with a Jacobian entry (< 2^31) stays below 2^60 and the sum
 * of six below 2^63. */
#define WRENCH_D_MAX (INT64_C(1) << 29)

void sp_wrench_step(sp_wrench_t *w, const sp_model_t *model, const sp_q8_t measured[SP_LEGS], sp_q30_t alpha)
{
    unsigned i;
    unsigned k;
    if (model == NULL) {
        w->have_model = 0u;
        w->valid = 0u;
        return;
    }
    if (w->have_model) {
        int32_t d[SP_LEGS]; /* F_model - F, N, Q8 */
        sp_flags_t flags = 0u;
        for (i = 0u; i < SP_LEGS; ++i) {
            int64_t v = (int64_t)w->model_force[i] - measured[i];
            d[i] = (int32_t)((v > WRENCH_D_MAX) ? WRENCH_D_MAX : ((v < -WRENCH_D_MAX) ? -WRENCH_D_MAX : v));
        }
        for (k = 0u; k < 6u; ++k) {
            int64_t acc = 0; /* (J^T d)_k, Q28 x Q8 = Q36 */
            int32_t raw;
            for (i = 0u; i < SP_LEGS; ++i) {
                acc += (int64_t)model->jac.j[i][k] * d[i];
            }
            raw = spi_narrow_floor(acc + (INT64_C(1) << 27), 28u, &flags);
            if (w->valid) {
                /* the step saturates at int32 (a jump of 8.4 MN is then
                 * followed at the filter's rate anyway) */
                int32_t e = spi_sat((int64_t)raw - w->wrench[k], &flags);
                raw = spi_sat((int64_t)w->wrench[k] +
                                  spi_narrow_floor((int64_t)alpha * e + (INT64_C(1) << 29), 30u, &flags),
                              &flags);
            }
            w->wrench[k] = raw;
        }
        w->valid = 1u;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        w->model_force[i] = model->force[i];
    }
    w->have_model = 1u;
}
