/* SPDX-License-Identifier: Apache-2.0 */
/* protocol_plain.c - the protocol codec as it was written by hand before
 * tools/dev/gen_proto_c.py generated it from the DBC: the plain
 * reference test_proto_codec.c holds the generated encoders and decoders
 * to, frame for frame and value for value. The shared steps it always had
 * are the generated codec's (link/proto_codec.h). */
#include "plain/protocol_plain.h"

#include "link/proto_codec.h" /* muldiv, clamp, clear, finish, precheck, reject: unchanged */

static sp_q24_t to_q24(int64_t v)
{
    int dummy = 0;
    return (sp_q24_t)clamp(v, INT32_MIN, INT32_MAX, &dummy);
}

/* Core units <-> raw signals. The ratios SP_CAN_<family>_RAW_PER_<unit>_NUM / _DEN (raw = value * NUM / DEN)
 * are generated from the DBC's factors into stewart_can.h (tools/dev/gen_can_c.py). */
#define I24_MAX 8388607
#define I24_MIN (-8388607) /* signed ranges are symmetric: the DBC's minimum */
static uint32_t q24_to_length(sp_q24_t q, int *sat)
{
    return (uint32_t)clamp(muldiv(q, SP_CAN_LENGTH_RAW_PER_Q24_M_NUM, SP_CAN_LENGTH_RAW_PER_Q24_M_DEN), 0, 16777215,
                           sat);
}
static sp_q24_t length_to_q24(int64_t raw)
{
    return to_q24(muldiv(raw, SP_CAN_LENGTH_RAW_PER_Q24_M_DEN, SP_CAN_LENGTH_RAW_PER_Q24_M_NUM));
}
/* AXIS_FEEDBACK's Length: 28 bits of a finer step (0.1 um) than the setpoints'. */
#define FB_LENGTH_MAX INT64_C(268435455)
static uint32_t q24_to_fb_length(sp_q24_t q, int *sat)
{
    return (uint32_t)clamp(
        muldiv(q, SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M_NUM, SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M_DEN), 0, FB_LENGTH_MAX,
        sat);
}
static sp_q24_t fb_length_to_q24(int64_t raw)
{
    return to_q24(muldiv(raw, SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M_DEN, SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M_NUM));
}
static int32_t q24_to_pose(sp_q24_t q, int *sat)
{
    return (int32_t)clamp(muldiv(q, SP_CAN_POSE_RAW_PER_Q24_M_RAD_NUM, SP_CAN_POSE_RAW_PER_Q24_M_RAD_DEN), I24_MIN,
                          I24_MAX, sat);
}
static sp_q24_t pose_to_q24(int64_t raw)
{
    return to_q24(muldiv(raw, SP_CAN_POSE_RAW_PER_Q24_M_RAD_DEN, SP_CAN_POSE_RAW_PER_Q24_M_RAD_NUM));
}
static int16_t q24_to_vel(sp_q24_t q, int *sat)
{
    return (int16_t)clamp(muldiv(q, SP_CAN_VELOCITY_RAW_PER_Q24_MPS_NUM, SP_CAN_VELOCITY_RAW_PER_Q24_MPS_DEN),
                          -INT16_MAX, INT16_MAX, sat);
}
static sp_q24_t vel_to_q24(int64_t raw)
{
    return to_q24(muldiv(raw, SP_CAN_VELOCITY_RAW_PER_Q24_MPS_DEN, SP_CAN_VELOCITY_RAW_PER_Q24_MPS_NUM));
}
static int32_t q8_to_force(sp_q8_t q, int *sat)
{
    return (int32_t)clamp(muldiv(q, SP_CAN_FORCE_RAW_PER_Q8_N_NUM, SP_CAN_FORCE_RAW_PER_Q8_N_DEN), I24_MIN, I24_MAX,
                          sat);
}
static sp_q8_t force_to_q8(int64_t raw)
{
    return (sp_q8_t)to_q24(muldiv(raw, SP_CAN_FORCE_RAW_PER_Q8_N_DEN, SP_CAN_FORCE_RAW_PER_Q8_N_NUM));
}
static int32_t q24_to_amp(sp_q24_t q, int *sat)
{
    return (int32_t)clamp(muldiv(q, SP_CAN_AMPLITUDE_RAW_PER_Q24_M_RAD_NUM, SP_CAN_AMPLITUDE_RAW_PER_Q24_M_RAD_DEN),
                          I24_MIN, I24_MAX, sat);
}
static sp_q24_t amp_to_q24(int64_t raw)
{
    return to_q24(muldiv(raw, SP_CAN_AMPLITUDE_RAW_PER_Q24_M_RAD_DEN, SP_CAN_AMPLITUDE_RAW_PER_Q24_M_RAD_NUM));
}
static uint16_t q24_to_freq(sp_q24_t q, int *sat)
{
    return (uint16_t)clamp(muldiv(q, SP_CAN_FREQUENCY_RAW_PER_Q24_HZ_NUM, SP_CAN_FREQUENCY_RAW_PER_Q24_HZ_DEN), 0,
                           UINT16_MAX, sat);
}
static sp_q24_t freq_to_q24(int64_t raw)
{
    return to_q24(muldiv(raw, SP_CAN_FREQUENCY_RAW_PER_Q24_HZ_DEN, SP_CAN_FREQUENCY_RAW_PER_Q24_HZ_NUM));
}
/* Pressures are whole pascals and 1 raw a whole number of them: the 1 kHz decode is a plain multiply. */
typedef char sp_pressure_raw_is_whole_pa[(SP_CAN_PRESSURE_RAW_PER_PA_NUM == 1) ? 1 : -1];
static uint16_t pa_to_pressure(uint32_t pa, int *sat)
{
    return (uint16_t)clamp(((int64_t)pa + SP_CAN_PRESSURE_RAW_PER_PA_DEN / 2) / SP_CAN_PRESSURE_RAW_PER_PA_DEN, 0,
                           UINT16_MAX, sat);
}
static uint32_t pressure_to_pa(uint16_t raw)
{
    return (uint32_t)raw * (uint32_t)SP_CAN_PRESSURE_RAW_PER_PA_DEN;
}
/* Wrench components: Q8 -> 0.25 N (or N m) raw is Q8 / 64; the decode is exact. */
#define I22_MAX 2097151
#define I22_MIN (-2097151) /* symmetric, as the other signed signals */
typedef char sp_wrench_raw_is_q8_div[(SP_CAN_WRENCH_RAW_PER_Q8_N_NM_NUM == 1) ? 1 : -1];
typedef char
    sp_wrench_max_matches[(SP_PROTO_WRENCH_MAX_Q8 == (int64_t)I22_MAX * SP_CAN_WRENCH_RAW_PER_Q8_N_NM_DEN) ? 1 : -1];
static int32_t q8_to_wrench(int32_t q, int *sat)
{
    return (int32_t)clamp(muldiv(q, SP_CAN_WRENCH_RAW_PER_Q8_N_NM_NUM, SP_CAN_WRENCH_RAW_PER_Q8_N_NM_DEN), I22_MIN,
                          I22_MAX, sat);
}
static int32_t wrench_to_q8(int32_t raw)
{
    return (int32_t)((int64_t)raw * SP_CAN_WRENCH_RAW_PER_Q8_N_NM_DEN);
}
/* OP_FORCE and FT_SENSOR wrench components: 1/32 N (N m) raw is Q8 / 8; the decode is exact. */
#define I20_MAX 524287
#define I20_MIN (-524287)
typedef char sp_ft_raw_is_q8_div[(SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_NUM == 1) ? 1 : -1];
typedef char
    sp_ft_max_matches[(SP_PROTO_FT_MAX_Q8 == (int64_t)I20_MAX * SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_DEN) ? 1 : -1];
static int32_t q8_to_ftw(int32_t q, int *sat)
{
    return (int32_t)clamp(muldiv(q, SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_NUM, SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_DEN),
                          I20_MIN, I20_MAX, sat);
}
/* 0 when every raw component is within the symmetric range, and then the Q8 values in q. */
static int ftw_to_q8(const int32_t raw[6], sp_q8_t q[6])
{
    for (uint32_t k = 0; k < 6u; k++) {
        if (raw[k] < I20_MIN || raw[k] > I20_MAX) {
            return -1;
        }
    }
    for (uint32_t k = 0; k < 6u; k++) {
        q[k] = (sp_q8_t)((int64_t)raw[k] * SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM_DEN);
    }
    return 0;
}
/* The fade time is whole milliseconds on both sides: raw = ms. */
typedef char sp_fade_raw_is_ms[(SP_CAN_FADE_TIME_RAW_PER_MS_NUM == 1) ? 1 : -1];
typedef char sp_fade_ms_is_raw[(SP_CAN_FADE_TIME_RAW_PER_MS_DEN == 1) ? 1 : -1];

/* 1 if any signed raw value is the (excluded) most negative one. */
static int below_i24(const int32_t *v, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++) {
        if (v[i] < I24_MIN) {
            return 1;
        }
    }
    return 0;
}

static void pose_to_bus(const sp_pose_t *p, int32_t out[6], int *sat)
{
    for (uint32_t k = 0; k < 3u; k++) {
        out[k] = q24_to_pose(p->pos[k], sat);
        out[3u + k] = q24_to_pose(p->rpy[k], sat);
    }
}

static void pose_from_bus(const int32_t in[6], sp_pose_t *p)
{
    for (uint32_t k = 0; k < 3u; k++) {
        p->pos[k] = pose_to_q24(in[k]);
        p->rpy[k] = pose_to_q24(in[3u + k]);
    }
}

/* ---- SYNC ---- */
sp_status_t plain_proto_encode_sync(const sp_msg_sync_t *m, uint8_t counter, uint8_t bus, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL) {
        return SP_E_ARG;
    }
    struct stewart_can_sync_t s;
    (void)stewart_can_sync_init(&s);
    s.tick = m->tick;
    s.hold = m->hold ? 1u : 0u;
    s.counter = (uint8_t)(counter & 0x0Fu);
    clear(f);
    return finish(f, SP_ID_SYNC, bus, stewart_can_sync_pack(f->data, &s, SP_CAN_MAX_DATA), STEWART_CAN_SYNC_LENGTH, 0);
}

sp_status_t plain_proto_decode_sync(const sp_can_frame_t *f, sp_msg_sync_t *m, uint8_t *counter,
                                    sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_SYNC, STEWART_CAN_SYNC_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_sync_t s;
    if (stewart_can_sync_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    m->tick = s.tick;
    m->hold = s.hold;
    *counter = s.counter;
    return SP_OK;
}

/* ---- AXIS_SETPOINTS ---- */
sp_status_t plain_proto_encode_setpoints(const sp_msg_setpoints_t *m, uint8_t counter, uint8_t bus, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL || m->mode > 1u) {
        return SP_E_ARG;
    }
    struct stewart_can_axis_setpoints_t s;
    int sat = 0;
    (void)stewart_can_axis_setpoints_init(&s);
    s.tick = m->tick;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.mode = m->mode;
    s.length_1 = q24_to_length(m->setpoint[0].length, &sat);
    s.velocity_1 = q24_to_vel(m->setpoint[0].velocity, &sat);
    s.force_1 = q8_to_force(m->setpoint[0].force, &sat);
    s.length_2 = q24_to_length(m->setpoint[1].length, &sat);
    s.velocity_2 = q24_to_vel(m->setpoint[1].velocity, &sat);
    s.force_2 = q8_to_force(m->setpoint[1].force, &sat);
    s.length_3 = q24_to_length(m->setpoint[2].length, &sat);
    s.velocity_3 = q24_to_vel(m->setpoint[2].velocity, &sat);
    s.force_3 = q8_to_force(m->setpoint[2].force, &sat);
    s.fault_reset = m->fault_reset ? 1u : 0u;
    s.block = m->block ? 1u : 0u;
    clear(f);
    return finish(f, SP_ID_AXIS_SETPOINTS, bus, stewart_can_axis_setpoints_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_AXIS_SETPOINTS_LENGTH, sat);
}

sp_status_t plain_proto_decode_setpoints(const sp_can_frame_t *f, sp_msg_setpoints_t *m, uint8_t *counter,
                                         sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_AXIS_SETPOINTS, STEWART_CAN_AXIS_SETPOINTS_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_axis_setpoints_t s;
    if (stewart_can_axis_setpoints_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t forces[3] = {s.force_1, s.force_2, s.force_3};
    if (s.mode > 1u || s.velocity_1 < -INT16_MAX || s.velocity_2 < -INT16_MAX || s.velocity_3 < -INT16_MAX ||
        below_i24(forces, 3u)) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->tick = s.tick;
    m->mode = s.mode;
    m->setpoint[0].length = length_to_q24(s.length_1);
    m->setpoint[0].velocity = vel_to_q24(s.velocity_1);
    m->setpoint[0].force = force_to_q8(s.force_1);
    m->setpoint[1].length = length_to_q24(s.length_2);
    m->setpoint[1].velocity = vel_to_q24(s.velocity_2);
    m->setpoint[1].force = force_to_q8(s.force_2);
    m->setpoint[2].length = length_to_q24(s.length_3);
    m->setpoint[2].velocity = vel_to_q24(s.velocity_3);
    m->setpoint[2].force = force_to_q8(s.force_3);
    m->fault_reset = s.fault_reset;
    m->block = s.block;
    *counter = s.counter;
    return SP_OK;
}

/* ---- AXIS_FEEDBACK_1..3 (same layout, one identifier per slot) ---- */
sp_status_t plain_proto_encode_feedback(const sp_msg_feedback_t *m, uint8_t slot, uint8_t counter, uint8_t bus,
                                        sp_can_frame_t *f)
{
    if (m == NULL || f == NULL || slot < 1u || slot > SP_AXIS_SLOTS || m->state > 3u) {
        return SP_E_ARG;
    }
    int sat = 0;
    struct stewart_can_axis_feedback_1_t s;
    (void)stewart_can_axis_feedback_1_init(&s);
    s.length = q24_to_fb_length(m->length, &sat);
    s.pressure_a = pa_to_pressure(m->pressure_a, &sat);
    s.pressure_b = pa_to_pressure(m->pressure_b, &sat);
    s.state = m->state;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.faults = m->faults;
    s.tick_echo = m->tick_echo;
    clear(f);
    int n;
    if (slot == 1u) {
        n = stewart_can_axis_feedback_1_pack(f->data, &s, SP_CAN_MAX_DATA);
    } else if (slot == 2u) {
        struct stewart_can_axis_feedback_2_t s2 = {.length = s.length,
                                                   .state = s.state,
                                                   .pressure_a = s.pressure_a,
                                                   .pressure_b = s.pressure_b,
                                                   .counter = s.counter,
                                                   .faults = s.faults,
                                                   .tick_echo = s.tick_echo,
                                                   .crc = 0u};
        n = stewart_can_axis_feedback_2_pack(f->data, &s2, SP_CAN_MAX_DATA);
    } else {
        struct stewart_can_axis_feedback_3_t s3 = {.length = s.length,
                                                   .state = s.state,
                                                   .pressure_a = s.pressure_a,
                                                   .pressure_b = s.pressure_b,
                                                   .counter = s.counter,
                                                   .faults = s.faults,
                                                   .tick_echo = s.tick_echo,
                                                   .crc = 0u};
        n = stewart_can_axis_feedback_3_pack(f->data, &s3, SP_CAN_MAX_DATA);
    }
    return finish(f, SP_ID_AXIS_FEEDBACK_1 + slot - 1u, bus, n, STEWART_CAN_AXIS_FEEDBACK_1_LENGTH, sat);
}

sp_status_t plain_proto_decode_feedback(const sp_can_frame_t *f, sp_msg_feedback_t *m, uint8_t *slot, uint8_t *counter,
                                        sp_proto_error_t *error)
{
    if (m == NULL || slot == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (f == NULL || f->id < SP_ID_AXIS_FEEDBACK_1 || f->id >= SP_ID_AXIS_FEEDBACK_1 + SP_AXIS_SLOTS) {
        return reject(error, SP_PROTO_UNKNOWN_ID);
    }
    if (precheck(f, f->id, STEWART_CAN_AXIS_FEEDBACK_1_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    uint8_t s_slot = (uint8_t)(f->id - SP_ID_AXIS_FEEDBACK_1 + 1u);
    struct stewart_can_axis_feedback_1_t s;
    int r;
    if (s_slot == 1u) {
        r = stewart_can_axis_feedback_1_unpack(&s, f->data, f->len);
    } else if (s_slot == 2u) {
        struct stewart_can_axis_feedback_2_t s2;
        r = stewart_can_axis_feedback_2_unpack(&s2, f->data, f->len);
        s.length = s2.length;
        s.pressure_a = s2.pressure_a;
        s.pressure_b = s2.pressure_b;
        s.state = s2.state;
        s.counter = s2.counter;
        s.faults = s2.faults;
        s.tick_echo = s2.tick_echo;
    } else {
        struct stewart_can_axis_feedback_3_t s3;
        r = stewart_can_axis_feedback_3_unpack(&s3, f->data, f->len);
        s.length = s3.length;
        s.pressure_a = s3.pressure_a;
        s.pressure_b = s3.pressure_b;
        s.state = s3.state;
        s.counter = s3.counter;
        s.faults = s3.faults;
        s.tick_echo = s3.tick_echo;
    }
    if (r != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    if (s.state > 3u) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->length = fb_length_to_q24(s.length);
    m->pressure_a = pressure_to_pa(s.pressure_a);
    m->pressure_b = pressure_to_pa(s.pressure_b);
    m->state = s.state;
    m->faults = s.faults;
    m->tick_echo = s.tick_echo;
    *slot = s_slot;
    *counter = s.counter;
    return SP_OK;
}

/* ---- OP_COMMAND ---- */
sp_status_t plain_proto_encode_command(const sp_msg_command_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL || m->command > SP_CMD_WIRE_MAX || m->axis > 5u || m->option > 1u) {
        return SP_E_ARG;
    }
    int sat = 0;
    struct stewart_can_op_command_t s;
    (void)stewart_can_op_command_init(&s);
    s.command = m->command;
    s.axis = m->axis;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.amplitude = q24_to_amp(m->amplitude, &sat);
    s.frequency = q24_to_freq(m->frequency, &sat);
    s.fade_time = (uint16_t)clamp(m->fade_ms, 0, UINT16_MAX, &sat);
    s.option = m->option;
    clear(f);
    return finish(f, SP_ID_OP_COMMAND, SP_BUS_OPS, stewart_can_op_command_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_OP_COMMAND_LENGTH, sat);
}

sp_status_t plain_proto_decode_command(const sp_can_frame_t *f, sp_msg_command_t *m, uint8_t *counter,
                                       sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_OP_COMMAND, STEWART_CAN_OP_COMMAND_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_op_command_t s;
    if (stewart_can_op_command_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    if (s.command > SP_CMD_WIRE_MAX || s.axis > 5u || s.option > 1u || below_i24(&s.amplitude, 1u)) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->command = s.command;
    m->axis = s.axis;
    m->amplitude = amp_to_q24(s.amplitude);
    m->frequency = freq_to_q24(s.frequency);
    m->fade_ms = s.fade_time;
    m->option = s.option;
    *counter = s.counter;
    return SP_OK;
}

/* ---- OP_TARGET_POSE ---- */
sp_status_t plain_proto_encode_target(const sp_pose_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL) {
        return SP_E_ARG;
    }
    int sat = 0;
    int32_t v[6];
    pose_to_bus(m, v, &sat);
    struct stewart_can_op_target_pose_t s;
    (void)stewart_can_op_target_pose_init(&s);
    s.x = v[0];
    s.y = v[1];
    s.z = v[2];
    s.roll = v[3];
    s.pitch = v[4];
    s.yaw = v[5];
    s.counter = (uint8_t)(counter & 0x0Fu);
    clear(f);
    return finish(f, SP_ID_OP_TARGET_POSE, SP_BUS_OPS, stewart_can_op_target_pose_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_OP_TARGET_POSE_LENGTH, sat);
}

sp_status_t plain_proto_decode_target(const sp_can_frame_t *f, sp_pose_t *m, uint8_t *counter, sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_OP_TARGET_POSE, STEWART_CAN_OP_TARGET_POSE_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_op_target_pose_t s;
    if (stewart_can_op_target_pose_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t v[6] = {s.x, s.y, s.z, s.roll, s.pitch, s.yaw};
    if (below_i24(v, 6u)) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    pose_from_bus(v, m);
    *counter = s.counter;
    return SP_OK;
}

/* ---- OP_HEARTBEAT ---- */
sp_status_t plain_proto_encode_heartbeat(uint8_t counter, sp_can_frame_t *f)
{
    if (f == NULL) {
        return SP_E_ARG;
    }
    struct stewart_can_op_heartbeat_t s;
    (void)stewart_can_op_heartbeat_init(&s);
    s.counter = (uint8_t)(counter & 0x0Fu);
    clear(f);
    return finish(f, SP_ID_OP_HEARTBEAT, SP_BUS_OPS, stewart_can_op_heartbeat_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_OP_HEARTBEAT_LENGTH, 0);
}

sp_status_t plain_proto_decode_heartbeat(const sp_can_frame_t *f, uint8_t *counter, sp_proto_error_t *error)
{
    if (counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_OP_HEARTBEAT, STEWART_CAN_OP_HEARTBEAT_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_op_heartbeat_t s;
    if (stewart_can_op_heartbeat_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    *counter = s.counter;
    return SP_OK;
}

/* ---- CTRL_STATUS ---- */
sp_status_t plain_proto_encode_status(const sp_msg_status_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL || m->state > 7u || m->force_mode > 4u || m->stop_reaction > 2u) {
        return SP_E_ARG;
    }
    int sat = 0;
    int32_t v[6];
    pose_to_bus(&m->estimate, v, &sat);
    struct stewart_can_ctrl_status_t s;
    (void)stewart_can_ctrl_status_init(&s);
    s.tick = m->tick;
    s.state = m->state;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.faults = m->faults;
    s.fk_iterations = (uint8_t)clamp(m->fk_iterations, 0, 15, &sat);
    s.estimate_valid = m->estimate_valid ? 1u : 0u;
    s.cmd_rejected = m->cmd_rejected ? 1u : 0u;
    s.drive_mode = m->drive_mode ? 1u : 0u;
    s.feed_forward = m->feedforward ? 1u : 0u;
    s.force_mode = m->force_mode;
    s.contact = m->contact ? 1u : 0u;
    s.drives_starting = m->drives_starting ? 1u : 0u;
    s.x = v[0];
    s.y = v[1];
    s.z = v[2];
    s.roll = v[3];
    s.pitch = v[4];
    s.yaw = v[5];
    s.reset_refused_legs = (uint8_t)(m->reset_refused_legs & 0x3Fu);
    s.reset_refused_cause = m->reset_refused_cause;
    s.force_unmeasured = (uint8_t)(m->force_unmeasured & 0x3Fu);
    s.refusals = (uint8_t)(m->refusals & 0x07u);
    s.stop_reaction = m->stop_reaction;
    clear(f);
    return finish(f, SP_ID_CTRL_STATUS, SP_BUS_OPS, stewart_can_ctrl_status_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_CTRL_STATUS_LENGTH, sat);
}

sp_status_t plain_proto_decode_status(const sp_can_frame_t *f, sp_msg_status_t *m, uint8_t *counter,
                                      sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_CTRL_STATUS, STEWART_CAN_CTRL_STATUS_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_ctrl_status_t s;
    if (stewart_can_ctrl_status_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t v[6] = {s.x, s.y, s.z, s.roll, s.pitch, s.yaw};
    if (s.state > 7u || s.fk_iterations > 15u || s.force_mode > 4u || s.stop_reaction > 2u || below_i24(v, 6u)) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->tick = s.tick;
    m->state = s.state;
    m->faults = s.faults;
    m->fk_iterations = s.fk_iterations;
    m->estimate_valid = s.estimate_valid;
    m->cmd_rejected = s.cmd_rejected;
    m->drive_mode = s.drive_mode;
    m->feedforward = s.feed_forward;
    m->reset_refused_legs = s.reset_refused_legs;
    m->reset_refused_cause = s.reset_refused_cause;
    m->force_mode = s.force_mode;
    m->contact = s.contact;
    m->drives_starting = s.drives_starting;
    m->force_unmeasured = s.force_unmeasured;
    m->refusals = s.refusals;
    m->stop_reaction = s.stop_reaction;
    pose_from_bus(v, &m->estimate);
    *counter = s.counter;
    return SP_OK;
}

/* ---- CTRL_MONITOR ---- */
sp_status_t plain_proto_encode_monitor(const sp_msg_monitor_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL) {
        return SP_E_ARG;
    }
    int sat = 0;
    int32_t v[6];
    pose_to_bus(&m->reference, v, &sat);
    struct stewart_can_ctrl_monitor_t s;
    (void)stewart_can_ctrl_monitor_init(&s);
    s.tick = m->tick;
    s.ref_x = v[0];
    s.ref_y = v[1];
    s.ref_z = v[2];
    s.ref_roll = v[3];
    s.ref_pitch = v[4];
    s.ref_yaw = v[5];
    s.length_sp_1 = q24_to_length(m->length_sp[0], &sat);
    s.length_sp_2 = q24_to_length(m->length_sp[1], &sat);
    s.length_sp_3 = q24_to_length(m->length_sp[2], &sat);
    s.length_sp_4 = q24_to_length(m->length_sp[3], &sat);
    s.length_sp_5 = q24_to_length(m->length_sp[4], &sat);
    s.length_sp_6 = q24_to_length(m->length_sp[5], &sat);
    s.force_ff_1 = q8_to_force(m->force_ff[0], &sat);
    s.force_ff_2 = q8_to_force(m->force_ff[1], &sat);
    s.force_ff_3 = q8_to_force(m->force_ff[2], &sat);
    s.force_ff_4 = q8_to_force(m->force_ff[3], &sat);
    s.force_ff_5 = q8_to_force(m->force_ff[4], &sat);
    s.force_ff_6 = q8_to_force(m->force_ff[5], &sat);
    s.counter = (uint8_t)(counter & 0x0Fu);
    clear(f);
    return finish(f, SP_ID_CTRL_MONITOR, SP_BUS_OPS, stewart_can_ctrl_monitor_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_CTRL_MONITOR_LENGTH, sat);
}

sp_status_t plain_proto_decode_monitor(const sp_can_frame_t *f, sp_msg_monitor_t *m, uint8_t *counter,
                                       sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_CTRL_MONITOR, STEWART_CAN_CTRL_MONITOR_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_ctrl_monitor_t s;
    if (stewart_can_ctrl_monitor_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t v[6] = {s.ref_x, s.ref_y, s.ref_z, s.ref_roll, s.ref_pitch, s.ref_yaw};
    const int32_t frc[6] = {s.force_ff_1, s.force_ff_2, s.force_ff_3, s.force_ff_4, s.force_ff_5, s.force_ff_6};
    if (below_i24(v, 6u) || below_i24(frc, 6u)) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->tick = s.tick;
    pose_from_bus(v, &m->reference);
    const uint32_t len[6] = {s.length_sp_1, s.length_sp_2, s.length_sp_3, s.length_sp_4, s.length_sp_5, s.length_sp_6};
    for (uint32_t i = 0; i < SP_LEGS; i++) {
        m->length_sp[i] = length_to_q24(len[i]);
        m->force_ff[i] = force_to_q8(frc[i]);
    }
    *counter = s.counter;
    return SP_OK;
}

/* ---- CTRL_WRENCH ---- */
sp_status_t plain_proto_encode_wrench(const sp_msg_wrench_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL) {
        return SP_E_ARG;
    }
    int sat = 0;
    struct stewart_can_ctrl_wrench_t s;
    (void)stewart_can_ctrl_wrench_init(&s);
    s.tick = m->tick;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.valid = m->valid ? 1u : 0u;
    s.fx = q8_to_wrench(m->wrench[0], &sat);
    s.fy = q8_to_wrench(m->wrench[1], &sat);
    s.fz = q8_to_wrench(m->wrench[2], &sat);
    s.mx = q8_to_wrench(m->wrench[3], &sat);
    s.my = q8_to_wrench(m->wrench[4], &sat);
    s.mz = q8_to_wrench(m->wrench[5], &sat);
    clear(f);
    return finish(f, SP_ID_CTRL_WRENCH, SP_BUS_OPS, stewart_can_ctrl_wrench_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_CTRL_WRENCH_LENGTH, sat);
}

sp_status_t plain_proto_decode_wrench(const sp_can_frame_t *f, sp_msg_wrench_t *m, uint8_t *counter,
                                      sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_CTRL_WRENCH, STEWART_CAN_CTRL_WRENCH_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_ctrl_wrench_t s;
    if (stewart_can_ctrl_wrench_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t v[6] = {s.fx, s.fy, s.fz, s.mx, s.my, s.mz};
    for (uint32_t k = 0; k < 6u; k++) {
        if (v[k] < I22_MIN || v[k] > I22_MAX) {
            return reject(error, SP_PROTO_OUT_OF_RANGE);
        }
    }
    m->tick = s.tick;
    m->valid = s.valid;
    for (uint32_t k = 0; k < 6u; k++) {
        m->wrench[k] = wrench_to_q8(v[k]);
    }
    *counter = s.counter;
    return SP_OK;
}

/* ---- OP_FORCE ---- */
sp_status_t plain_proto_encode_force(const sp_msg_force_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL || m->mask > 63u) {
        return SP_E_ARG;
    }
    int sat = 0;
    struct stewart_can_op_force_t s;
    (void)stewart_can_op_force_init(&s);
    s.mask = m->mask;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.fx = q8_to_ftw(m->target[0], &sat);
    s.fy = q8_to_ftw(m->target[1], &sat);
    s.fz = q8_to_ftw(m->target[2], &sat);
    s.mx = q8_to_ftw(m->target[3], &sat);
    s.my = q8_to_ftw(m->target[4], &sat);
    s.mz = q8_to_ftw(m->target[5], &sat);
    clear(f);
    return finish(f, SP_ID_OP_FORCE, SP_BUS_OPS, stewart_can_op_force_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_OP_FORCE_LENGTH, sat);
}

sp_status_t plain_proto_decode_force(const sp_can_frame_t *f, sp_msg_force_t *m, uint8_t *counter,
                                     sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_OP_FORCE, STEWART_CAN_OP_FORCE_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_op_force_t s;
    if (stewart_can_op_force_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t v[6] = {s.fx, s.fy, s.fz, s.mx, s.my, s.mz};
    sp_q8_t q[6];
    if (s.mask > 63u || ftw_to_q8(v, q) != 0) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->mask = s.mask;
    for (uint32_t k = 0; k < 6u; k++) {
        m->target[k] = q[k];
    }
    *counter = s.counter;
    return SP_OK;
}

/* ---- OP_FORCE_PARAMS ---- */
static int force_params_ok(uint32_t mask, uint32_t mode, int64_t mass, int64_t damping, int64_t stiffness)
{
    return mask >= 1u && mask <= 63u && (mode == 1u || mode == 2u) && mass >= SP_PROTO_MASS_MIN_Q16 &&
           mass <= SP_PROTO_MASS_MAX_Q16 && damping >= SP_PROTO_DAMPING_MIN && damping <= SP_PROTO_DAMPING_MAX &&
           stiffness >= 0 && stiffness <= SP_PROTO_STIFFNESS_MAX;
}

sp_status_t plain_proto_encode_force_params(const sp_msg_force_params_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL || !force_params_ok(m->mask, m->mode, m->mass, m->damping, m->stiffness)) {
        return SP_E_ARG;
    }
    struct stewart_can_op_force_params_t s;
    (void)stewart_can_op_force_params_init(&s);
    s.mask = m->mask;
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.mode = m->mode;
    /* 0.1 kg: Q16 x 10 / 65536, and 10 N s/m, rounded (both positive) */
    s.mass = (uint16_t)(((int64_t)m->mass * 10 + 32768) >> 16);
    s.damping = (uint32_t)((m->damping + 5) / 10);
    s.stiffness = (uint32_t)m->stiffness;
    clear(f);
    return finish(f, SP_ID_OP_FORCE_PARAMS, SP_BUS_OPS, stewart_can_op_force_params_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_OP_FORCE_PARAMS_LENGTH, 0);
}

sp_status_t plain_proto_decode_force_params(const sp_can_frame_t *f, sp_msg_force_params_t *m, uint8_t *counter,
                                            sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_OP_FORCE_PARAMS, STEWART_CAN_OP_FORCE_PARAMS_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_op_force_params_t s;
    if (stewart_can_op_force_params_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    int64_t mass = ((int64_t)s.mass * 65536 + 5) / 10; /* Q16, rounded */
    int64_t damping = (int64_t)s.damping * 10;
    if (!force_params_ok(s.mask, s.mode, mass, damping, (int64_t)s.stiffness)) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    m->mask = s.mask;
    m->mode = s.mode;
    m->mass = (sp_q16_t)mass;
    m->damping = (int32_t)damping;
    m->stiffness = (int32_t)s.stiffness;
    *counter = s.counter;
    return SP_OK;
}

/* ---- FT_SENSOR ---- */
sp_status_t plain_proto_encode_ft(const sp_msg_ft_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL) {
        return SP_E_ARG;
    }
    int sat = 0;
    struct stewart_can_ft_sensor_t s;
    (void)stewart_can_ft_sensor_init(&s);
    s.fx = q8_to_ftw(m->wrench[0], &sat);
    s.fy = q8_to_ftw(m->wrench[1], &sat);
    s.fz = q8_to_ftw(m->wrench[2], &sat);
    s.mx = q8_to_ftw(m->wrench[3], &sat);
    s.my = q8_to_ftw(m->wrench[4], &sat);
    s.mz = q8_to_ftw(m->wrench[5], &sat);
    s.saturated = m->saturated ? 1u : 0u;
    s.counter = (uint8_t)(counter & 0x0Fu);
    clear(f);
    return finish(f, SP_ID_FT_SENSOR, SP_BUS_AXIS_B, stewart_can_ft_sensor_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_FT_SENSOR_LENGTH, sat);
}

sp_status_t plain_proto_decode_ft(const sp_can_frame_t *f, sp_msg_ft_t *m, uint8_t *counter, sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_FT_SENSOR, STEWART_CAN_FT_SENSOR_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_ft_sensor_t s;
    if (stewart_can_ft_sensor_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    const int32_t v[6] = {s.fx, s.fy, s.fz, s.mx, s.my, s.mz};
    sp_q8_t q[6];
    if (ftw_to_q8(v, q) != 0) {
        return reject(error, SP_PROTO_OUT_OF_RANGE);
    }
    for (uint32_t k = 0; k < 6u; k++) {
        m->wrench[k] = q[k];
    }
    m->saturated = s.saturated;
    *counter = s.counter;
    return SP_OK;
}

/* ---- CTRL_AUTH ---- */
static uint16_t sat16(uint32_t v)
{
    return (uint16_t)(v > UINT16_MAX ? UINT16_MAX : v);
}

sp_status_t plain_proto_encode_auth(const sp_msg_auth_t *m, uint8_t counter, sp_can_frame_t *f)
{
    if (m == NULL || f == NULL) {
        return SP_E_ARG;
    }
    struct stewart_can_ctrl_auth_t s;
    (void)stewart_can_ctrl_auth_init(&s);
    s.session = m->session;
    s.last_counter = m->last_counter;
    s.bad_tag = sat16(m->bad_tag);
    s.replayed = sat16(m->replayed);
    s.counter = (uint8_t)(counter & 0x0Fu);
    s.key_set = m->key_set ? 1u : 0u;
    clear(f);
    return finish(f, SP_ID_CTRL_AUTH, SP_BUS_OPS, stewart_can_ctrl_auth_pack(f->data, &s, SP_CAN_MAX_DATA),
                  STEWART_CAN_CTRL_AUTH_LENGTH, 0);
}

sp_status_t plain_proto_decode_auth(const sp_can_frame_t *f, sp_msg_auth_t *m, uint8_t *counter,
                                    sp_proto_error_t *error)
{
    if (m == NULL || counter == NULL) {
        return SP_E_ARG;
    }
    if (precheck(f, SP_ID_CTRL_AUTH, STEWART_CAN_CTRL_AUTH_LENGTH, error) != SP_OK) {
        return SP_E_FRAME;
    }
    struct stewart_can_ctrl_auth_t s;
    if (stewart_can_ctrl_auth_unpack(&s, f->data, f->len) != 0) {
        return reject(error, SP_PROTO_BAD_LENGTH);
    }
    m->session = s.session;
    m->last_counter = s.last_counter;
    m->bad_tag = s.bad_tag;
    m->replayed = s.replayed;
    m->key_set = s.key_set;
    *counter = s.counter;
    return SP_OK;
}
