/* SPDX-License-Identifier: Apache-2.0 */
/* The protocol codec generated from the DBC (tools/dev/gen_proto_c.py)
 * against the hand-written one it replaced (support/plain/protocol_plain.c):
 * random and boundary values through every encoder give the same status and
 * the same frame; random, mutated and boundary frames through every decoder
 * give the same status, rejection reason, counter and values. A change of
 * the DBC meant to change the codec changes the plain reference with it.
 * CTRL_IDENTITY came after the plain codec and has no counterpart there:
 * its frame is held to the DBC's layout byte by byte instead. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "plain/protocol_plain.h"
#include "stewart_can.h"
#include "test_util.h"

#define ENC_ROUNDS 20000u
#define DEC_ROUNDS 4000u

static uint64_t rng = UINT64_C(0x5EED0C0DEC);

/* The raw limits of the scaled signals, as values of the core: where the
 * encoders saturate and round. */
static int32_t boundary(uint64_t *s)
{
    static const struct {
        int64_t raw, num, den;
    } lim[] = {
        {16777215, SP_CAN_LENGTH_RAW_PER_Q24_M_NUM, SP_CAN_LENGTH_RAW_PER_Q24_M_DEN},
        {268435455, SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M_NUM, SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M_DEN},
        {8388607, SP_CAN_POSE_RAW_PER_Q24_M_RAD_NUM, SP_CAN_POSE_RAW_PER_Q24_M_RAD_DEN},
        {32767, SP_CAN_VELOCITY_RAW_PER_Q24_MPS_NUM, SP_CAN_VELOCITY_RAW_PER_Q24_MPS_DEN},
        {8388607, SP_CAN_FORCE_RAW_PER_Q8_N_NUM, SP_CAN_FORCE_RAW_PER_Q8_N_DEN},
        {8388607, SP_CAN_AMPLITUDE_RAW_PER_Q24_M_RAD_NUM, SP_CAN_AMPLITUDE_RAW_PER_Q24_M_RAD_DEN},
        {65535, SP_CAN_FREQUENCY_RAW_PER_Q24_HZ_NUM, SP_CAN_FREQUENCY_RAW_PER_Q24_HZ_DEN},
        {65535, SP_CAN_PRESSURE_RAW_PER_PA_NUM, SP_CAN_PRESSURE_RAW_PER_PA_DEN},
        {2097151, SP_CAN_WRENCH_RAW_PER_Q8_N_NM_NUM, SP_CAN_WRENCH_RAW_PER_Q8_N_NM_DEN},
        {524287, SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_NUM, SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_DEN},
        {65535, SP_CAN_FADE_TIME_RAW_PER_MS_NUM, SP_CAN_FADE_TIME_RAW_PER_MS_DEN},
        {1, 1, 1},
        {0, 1, 1},
    };
    uint64_t r = tu_next(s);
    size_t k = (size_t)(r % (sizeof lim / sizeof lim[0]));
    int64_t v = lim[k].raw * lim[k].den / lim[k].num + (int64_t)((r >> 8) % 2001u) - 1000;
    if ((r >> 40) & 1u) {
        v = -v;
    }
    return (int32_t)(v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : v);
}

/* Any int32, spread over every magnitude and the signals' limits. */
static int32_t v32(void)
{
    switch (tu_next(&rng) % 4u) {
    case 0:
        return tu_i32(&rng);
    case 1:
        return tu_i32_logscale(&rng);
    case 2:
        return (tu_next(&rng) & 1u) ? INT32_MAX - (int32_t)(tu_next(&rng) % 3u)
                                    : INT32_MIN + (int32_t)(tu_next(&rng) % 3u);
    default:
        return boundary(&rng);
    }
}

/* A small code: mostly within an enumeration's range, sometimes past it. */
static uint8_t small(void)
{
    uint64_t r = tu_next(&rng);
    return (uint8_t)((r & 3u) == 0u ? (r >> 8) : (r >> 8) % 17u);
}

static void fill(void *p, size_t n)
{
    uint8_t *b = p;
    for (size_t i = 0; i < n; i++) {
        b[i] = (uint8_t)tu_next(&rng);
    }
}

static void same_frame(sp_status_t a, sp_status_t b, const sp_can_frame_t *fa, const sp_can_frame_t *fb)
{
    assert_int_equal(a, b);
    assert_int_equal(fa->id, fb->id);
    assert_int_equal(fa->bus, fb->bus);
    assert_int_equal(fa->len, fb->len);
    assert_int_equal(fa->flags, fb->flags);
    assert_memory_equal(fa->data, fb->data, SP_CAN_MAX_DATA);
}

static void pose(sp_pose_t *p)
{
    for (int k = 0; k < 3; k++) {
        p->pos[k] = v32();
        p->rpy[k] = v32();
    }
}

/* Encoders: a random message of each kind through both; the frames the
 * plain one made are kept for the decoders. */
static sp_can_frame_t made[64];
static size_t n_made;

static void keep(const sp_can_frame_t *f)
{
    made[n_made % 64u] = *f;
    n_made++;
}

#define ENC(call_args_gen, call_args_plain)                                                                            \
    do {                                                                                                               \
        sp_can_frame_t fa, fb;                                                                                         \
        memset(&fa, 0x5A, sizeof fa);                                                                                  \
        memset(&fb, 0x5A, sizeof fb);                                                                                  \
        sp_status_t ra = call_args_gen;                                                                                \
        sp_status_t rb = call_args_plain;                                                                              \
        same_frame(ra, rb, &fa, &fb);                                                                                  \
        if (rb != SP_E_ARG) {                                                                                          \
            keep(&fb);                                                                                                 \
        }                                                                                                              \
    } while (0)

static void encode_round(uint8_t c, uint8_t bus)
{
    sp_msg_sync_t sy;
    fill(&sy, sizeof sy);
    ENC(sp_proto_encode_sync(&sy, c, bus, &fa), plain_proto_encode_sync(&sy, c, bus, &fb));

    sp_msg_setpoints_t sp;
    fill(&sp, sizeof sp);
    sp.mode = small();
    for (int k = 0; k < 3; k++) {
        sp.setpoint[k].length = v32();
        sp.setpoint[k].velocity = v32();
        sp.setpoint[k].force = v32();
    }
    ENC(sp_proto_encode_setpoints(&sp, c, bus, &fa), plain_proto_encode_setpoints(&sp, c, bus, &fb));

    sp_msg_feedback_t fbk;
    fill(&fbk, sizeof fbk);
    fbk.length = v32();
    fbk.pressure_a = (uint32_t)v32();
    fbk.pressure_b = (uint32_t)v32();
    fbk.state = small();
    uint8_t slot = (uint8_t)(tu_next(&rng) % 5u);
    ENC(sp_proto_encode_feedback(&fbk, slot, c, bus, &fa), plain_proto_encode_feedback(&fbk, slot, c, bus, &fb));

    sp_msg_command_t cmd;
    fill(&cmd, sizeof cmd);
    cmd.command = small();
    cmd.axis = small();
    cmd.option = small();
    cmd.amplitude = v32();
    cmd.frequency = v32();
    cmd.fade_ms = (tu_next(&rng) & 1u) ? (uint32_t)v32() : (uint32_t)(tu_next(&rng) % 70000u);
    ENC(sp_proto_encode_command(&cmd, c, &fa), plain_proto_encode_command(&cmd, c, &fb));

    sp_pose_t tp;
    pose(&tp);
    ENC(sp_proto_encode_target(&tp, c, &fa), plain_proto_encode_target(&tp, c, &fb));

    ENC(sp_proto_encode_heartbeat(c, &fa), plain_proto_encode_heartbeat(c, &fb));

    sp_msg_status_t st;
    fill(&st, sizeof st);
    st.state = small();
    st.force_mode = small();
    st.fk_iterations = small();
    st.stop_reaction = small();
    pose(&st.estimate);
    ENC(sp_proto_encode_status(&st, c, &fa), plain_proto_encode_status(&st, c, &fb));

    sp_msg_monitor_t mo;
    fill(&mo, sizeof mo);
    pose(&mo.reference);
    for (int k = 0; k < SP_LEGS; k++) {
        mo.length_sp[k] = v32();
        mo.force_ff[k] = v32();
    }
    ENC(sp_proto_encode_monitor(&mo, c, &fa), plain_proto_encode_monitor(&mo, c, &fb));

    sp_msg_wrench_t wr;
    fill(&wr, sizeof wr);
    for (int k = 0; k < 6; k++) {
        wr.wrench[k] = v32();
    }
    ENC(sp_proto_encode_wrench(&wr, c, &fa), plain_proto_encode_wrench(&wr, c, &fb));

    sp_msg_force_t fo;
    fill(&fo, sizeof fo);
    fo.mask = (uint8_t)(small() * 4u);
    for (int k = 0; k < 6; k++) {
        fo.target[k] = v32();
    }
    ENC(sp_proto_encode_force(&fo, c, &fa), plain_proto_encode_force(&fo, c, &fb));

    sp_msg_force_params_t fp;
    fill(&fp, sizeof fp);
    fp.mask = (uint8_t)(small() * 4u);
    fp.mode = (uint8_t)(small() % 4u);
    int32_t d = (int32_t)(tu_next(&rng) % 7u) - 3;
    switch (tu_next(&rng) % 4u) {
    case 0:
        fp.mass = SP_PROTO_MASS_MIN_Q16 + d;
        break;
    case 1:
        fp.mass = SP_PROTO_MASS_MAX_Q16 + d;
        break;
    case 2:
        fp.mass = (sp_q16_t)(tu_next(&rng) % (uint64_t)SP_PROTO_MASS_MAX_Q16);
        break;
    default:
        fp.mass = v32();
    }
    fp.damping = (tu_next(&rng) & 1u)   ? SP_PROTO_DAMPING_MIN + d
                 : (tu_next(&rng) & 1u) ? SP_PROTO_DAMPING_MAX + d
                                        : (int32_t)(tu_next(&rng) % (uint64_t)SP_PROTO_DAMPING_MAX);
    fp.stiffness = (tu_next(&rng) & 1u)   ? SP_PROTO_STIFFNESS_MAX + d
                   : (tu_next(&rng) & 1u) ? d
                                          : (int32_t)(tu_next(&rng) % (uint64_t)SP_PROTO_STIFFNESS_MAX);
    ENC(sp_proto_encode_force_params(&fp, c, &fa), plain_proto_encode_force_params(&fp, c, &fb));

    sp_msg_ft_t ft;
    fill(&ft, sizeof ft);
    for (int k = 0; k < 6; k++) {
        ft.wrench[k] = v32();
    }
    ENC(sp_proto_encode_ft(&ft, c, &fa), plain_proto_encode_ft(&ft, c, &fb));

    sp_msg_auth_t au;
    fill(&au, sizeof au);
    if (tu_next(&rng) & 1u) {
        au.bad_tag = (uint32_t)(tu_next(&rng) % 70000u);
        au.replayed = (uint32_t)(tu_next(&rng) % 70000u);
    }
    ENC(sp_proto_encode_auth(&au, c, &fa), plain_proto_encode_auth(&au, c, &fb));
}

static void test_encoders_match_the_plain_ones(void **state)
{
    (void)state;
    for (uint32_t i = 0; i < ENC_ROUNDS; i++) {
        encode_round((uint8_t)tu_next(&rng), (uint8_t)(tu_next(&rng) % 4u));
    }
    /* NULL arguments */
    sp_can_frame_t f;
    sp_msg_sync_t sy = {0};
    assert_int_equal(sp_proto_encode_sync(NULL, 0, 0, &f), plain_proto_encode_sync(NULL, 0, 0, &f));
    assert_int_equal(sp_proto_encode_sync(&sy, 0, 0, NULL), plain_proto_encode_sync(&sy, 0, 0, NULL));
    assert_int_equal(sp_proto_encode_heartbeat(0, NULL), plain_proto_encode_heartbeat(0, NULL));
}

/* Decoders: one frame through both, every output compared (each output
 * starts as the same pattern, so "untouched on error" is compared too). */
#define DEC(type, gen_call, plain_call)                                                                                \
    do {                                                                                                               \
        type ma, mb;                                                                                                   \
        uint8_t ca = 0xEE, cb = 0xEE, sa = 0xEE, sb = 0xEE;                                                            \
        sp_proto_error_t ea = SP_PROTO_ERRORS, eb = SP_PROTO_ERRORS;                                                   \
        memset(&ma, 0xA5, sizeof ma);                                                                                  \
        memset(&mb, 0xA5, sizeof mb);                                                                                  \
        sp_status_t ra = gen_call;                                                                                     \
        sp_status_t rb = plain_call;                                                                                   \
        (void)sa;                                                                                                      \
        (void)sb;                                                                                                      \
        assert_int_equal(ra, rb);                                                                                      \
        assert_int_equal(ea, eb);                                                                                      \
        assert_int_equal(ca, cb);                                                                                      \
        assert_int_equal(sa, sb);                                                                                      \
        assert_memory_equal(&ma, &mb, sizeof ma);                                                                      \
        ok += (rb == SP_OK);                                                                                           \
    } while (0)

static uint32_t ok;

static void decode_all(const sp_can_frame_t *f)
{
    DEC(sp_msg_sync_t, sp_proto_decode_sync(f, &ma, &ca, &ea), plain_proto_decode_sync(f, &mb, &cb, &eb));
    DEC(sp_msg_setpoints_t, sp_proto_decode_setpoints(f, &ma, &ca, &ea),
        plain_proto_decode_setpoints(f, &mb, &cb, &eb));
    DEC(sp_msg_feedback_t, sp_proto_decode_feedback(f, &ma, &sa, &ca, &ea),
        plain_proto_decode_feedback(f, &mb, &sb, &cb, &eb));
    DEC(sp_msg_command_t, sp_proto_decode_command(f, &ma, &ca, &ea), plain_proto_decode_command(f, &mb, &cb, &eb));
    DEC(sp_pose_t, sp_proto_decode_target(f, &ma, &ca, &ea), plain_proto_decode_target(f, &mb, &cb, &eb));
    DEC(uint8_t, sp_proto_decode_heartbeat(f, &ca, &ea), plain_proto_decode_heartbeat(f, &cb, &eb));
    DEC(sp_msg_status_t, sp_proto_decode_status(f, &ma, &ca, &ea), plain_proto_decode_status(f, &mb, &cb, &eb));
    DEC(sp_msg_monitor_t, sp_proto_decode_monitor(f, &ma, &ca, &ea), plain_proto_decode_monitor(f, &mb, &cb, &eb));
    DEC(sp_msg_wrench_t, sp_proto_decode_wrench(f, &ma, &ca, &ea), plain_proto_decode_wrench(f, &mb, &cb, &eb));
    DEC(sp_msg_force_t, sp_proto_decode_force(f, &ma, &ca, &ea), plain_proto_decode_force(f, &mb, &cb, &eb));
    DEC(sp_msg_force_params_t, sp_proto_decode_force_params(f, &ma, &ca, &ea),
        plain_proto_decode_force_params(f, &mb, &cb, &eb));
    DEC(sp_msg_ft_t, sp_proto_decode_ft(f, &ma, &ca, &ea), plain_proto_decode_ft(f, &mb, &cb, &eb));
    DEC(sp_msg_auth_t, sp_proto_decode_auth(f, &ma, &ca, &ea), plain_proto_decode_auth(f, &mb, &cb, &eb));
}

/* A kept frame, changed as a bus or a sender might: bits flipped, a byte
 * set to a sign pattern, the CRC sealed again or not, another length or
 * identifier. */
static void mutate(sp_can_frame_t *f)
{
    uint64_t r = tu_next(&rng);
    uint32_t n = (uint32_t)(r % 4u);
    for (uint32_t i = 0; i < n && f->len > 0u; i++) {
        uint32_t bit = (uint32_t)(tu_next(&rng) % (8u * f->len));
        f->data[bit / 8u] = (uint8_t)(f->data[bit / 8u] ^ (1u << (bit % 8u)));
    }
    if ((r >> 4) % 4u == 0u && f->len > 0u) {
        static const uint8_t pat[] = {0x00, 0x01, 0x7F, 0x80, 0xFF, 0xFE};
        f->data[tu_next(&rng) % f->len] = pat[tu_next(&rng) % sizeof pat];
    }
    if ((r >> 8) % 8u != 0u) {
        (void)sp_e2e_seal(f);
    }
    if ((r >> 12) % 32u == 0u) {
        f->len = (uint8_t)(tu_next(&rng) % 65u);
    }
    if ((r >> 20) % 32u == 0u) {
        f->id = (uint32_t)(tu_next(&rng) % 0x110u);
    }
}

static void test_decoders_match_the_plain_ones(void **state)
{
    (void)state;
    decode_all(NULL);
    for (uint32_t i = 0; i < DEC_ROUNDS; i++) {
        n_made = 0;
        encode_round((uint8_t)tu_next(&rng), (uint8_t)(tu_next(&rng) % 3u));
        for (size_t k = 0; k < n_made && k < 64u; k++) {
            sp_can_frame_t f = made[k];
            decode_all(&f);
            mutate(&f);
            decode_all(&f);
        }
    }
    assert_true(ok > DEC_ROUNDS * 12u); /* most kept frames decode: the values are compared, not just the errors */
}

/* CTRL_IDENTITY against the DBC's layout: version bytes 0-2, Port bits
 * 24-27, Counter 28-31, ProtocolHash bytes 4-7 little-endian, CRC-8 in byte
 * 11; round trip for every port, an unknown port refused both ways. */
static void test_identity_frame_is_the_dbcs_layout(void **state)
{
    (void)state;
    for (uint32_t i = 0; i < 300u; i++) {
        uint64_t r = tu_next(&rng);
        sp_msg_identity_t m = {(uint8_t)r, (uint8_t)(r >> 8), (uint8_t)(r >> 16), (uint8_t)(i % 3u),
                               (uint32_t)(r >> 32)};
        uint8_t c = (uint8_t)(i % 16u);
        sp_can_frame_t f;
        assert_int_equal(sp_proto_encode_identity(&m, c, &f), SP_OK);
        assert_int_equal(f.id, SP_ID_CTRL_IDENTITY);
        assert_int_equal(f.bus, SP_BUS_OPS);
        assert_int_equal(f.len, 12u);
        assert_int_equal(f.data[0], m.major);
        assert_int_equal(f.data[1], m.minor);
        assert_int_equal(f.data[2], m.patch);
        assert_int_equal(f.data[3], (uint8_t)(m.port | (c << 4)));
        uint32_t h = (uint32_t)f.data[4] | ((uint32_t)f.data[5] << 8) | ((uint32_t)f.data[6] << 16) |
                     ((uint32_t)f.data[7] << 24);
        assert_int_equal(h, m.protocol_hash);
        assert_int_equal(f.data[8] | f.data[9] | f.data[10], 0);
        sp_msg_identity_t back;
        uint8_t cb = 0xEE;
        sp_proto_error_t e = SP_PROTO_ERRORS;
        assert_int_equal(sp_proto_decode_identity(&f, &back, &cb, &e), SP_OK);
        assert_memory_equal(&back, &m, sizeof m);
        assert_int_equal(cb, c);
        f.data[3] = (uint8_t)((f.data[3] & 0xF0u) | 3u);
        assert_int_equal(sp_e2e_seal(&f), SP_OK);
        assert_int_equal(sp_proto_decode_identity(&f, &back, &cb, &e), SP_E_FRAME);
        assert_int_equal(e, SP_PROTO_OUT_OF_RANGE);
        m.port = 3u;
        assert_int_equal(sp_proto_encode_identity(&m, c, &f), SP_E_ARG);
    }
}

/* OP_FORCE_PARAMS's ranges, raw value by raw value around each limit
 * (and every mass). */
static void test_force_params_every_raw_limit(void **state)
{
    (void)state;
    const uint32_t edges[] = {0u, 1u, 9u, 10u, 11u, 99u, 100u, 9999999u, 10000000u, 10000001u, 16777215u};
    for (uint32_t mass = 0; mass <= 65535u; mass++) {
        for (size_t k = 0; k < sizeof edges / sizeof edges[0]; k++) {
            struct stewart_can_op_force_params_t s;
            (void)stewart_can_op_force_params_init(&s);
            s.mask = (uint8_t)(k == 0u ? 0u : 1u + (mass + k) % 63u); /* valid but for k 0 and 1 */
            s.mode = (uint8_t)(k == 1u ? 3u : 1u + mass % 2u);
            s.mass = (uint16_t)mass;
            s.damping = edges[k];
            s.stiffness = edges[(k + mass) % (sizeof edges / sizeof edges[0])];
            sp_can_frame_t f;
            memset(&f, 0, sizeof f);
            assert_int_equal(stewart_can_op_force_params_pack(f.data, &s, SP_CAN_MAX_DATA),
                             STEWART_CAN_OP_FORCE_PARAMS_LENGTH);
            f.id = SP_ID_OP_FORCE_PARAMS;
            f.len = STEWART_CAN_OP_FORCE_PARAMS_LENGTH;
            assert_int_equal(sp_e2e_seal(&f), SP_OK);
            DEC(sp_msg_force_params_t, sp_proto_decode_force_params(&f, &ma, &ca, &ea),
                plain_proto_decode_force_params(&f, &mb, &cb, &eb));
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_encoders_match_the_plain_ones),
        cmocka_unit_test(test_decoders_match_the_plain_ones),
        cmocka_unit_test(test_force_params_every_raw_limit),
        cmocka_unit_test(test_identity_frame_is_the_dbcs_layout),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
