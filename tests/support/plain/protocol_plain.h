/* SPDX-License-Identifier: Apache-2.0 */
/* protocol_plain.h - the hand-written protocol codec (protocol_plain.c),
 * the plain reference of the generated one: the same calls as
 * sp/link/protocol.h's encoders and decoders, prefixed plain_proto_. */
#ifndef PROTOCOL_PLAIN_H
#define PROTOCOL_PLAIN_H

#include "sp/link/protocol.h"

sp_status_t plain_proto_encode_auth(const sp_msg_auth_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_decode_auth(const sp_can_frame_t *f, sp_msg_auth_t *m, uint8_t *counter,
                                    sp_proto_error_t *error);
sp_status_t plain_proto_encode_sync(const sp_msg_sync_t *m, uint8_t counter, uint8_t bus, sp_can_frame_t *f);
sp_status_t plain_proto_encode_setpoints(const sp_msg_setpoints_t *m, uint8_t counter, uint8_t bus, sp_can_frame_t *f);
sp_status_t plain_proto_encode_feedback(const sp_msg_feedback_t *m, uint8_t slot, uint8_t counter, uint8_t bus,
                                        sp_can_frame_t *f);
sp_status_t plain_proto_encode_command(const sp_msg_command_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_encode_target(const sp_pose_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_encode_status(const sp_msg_status_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_encode_monitor(const sp_msg_monitor_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_encode_wrench(const sp_msg_wrench_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_encode_force(const sp_msg_force_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_decode_force(const sp_can_frame_t *f, sp_msg_force_t *m, uint8_t *counter,
                                     sp_proto_error_t *error);
sp_status_t plain_proto_encode_force_params(const sp_msg_force_params_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_decode_force_params(const sp_can_frame_t *f, sp_msg_force_params_t *m, uint8_t *counter,
                                            sp_proto_error_t *error);
sp_status_t plain_proto_encode_ft(const sp_msg_ft_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_decode_ft(const sp_can_frame_t *f, sp_msg_ft_t *m, uint8_t *counter, sp_proto_error_t *error);
sp_status_t plain_proto_encode_heartbeat(uint8_t counter, sp_can_frame_t *f);
sp_status_t plain_proto_decode_heartbeat(const sp_can_frame_t *f, uint8_t *counter, sp_proto_error_t *error);
sp_status_t plain_proto_decode_sync(const sp_can_frame_t *f, sp_msg_sync_t *m, uint8_t *counter,
                                    sp_proto_error_t *error);
sp_status_t plain_proto_decode_setpoints(const sp_can_frame_t *f, sp_msg_setpoints_t *m, uint8_t *counter,
                                         sp_proto_error_t *error);
sp_status_t plain_proto_decode_feedback(const sp_can_frame_t *f, sp_msg_feedback_t *m, uint8_t *slot, uint8_t *counter,
                                        sp_proto_error_t *error);
sp_status_t plain_proto_decode_command(const sp_can_frame_t *f, sp_msg_command_t *m, uint8_t *counter,
                                       sp_proto_error_t *error);
sp_status_t plain_proto_decode_target(const sp_can_frame_t *f, sp_pose_t *m, uint8_t *counter, sp_proto_error_t *error);
sp_status_t plain_proto_decode_status(const sp_can_frame_t *f, sp_msg_status_t *m, uint8_t *counter,
                                      sp_proto_error_t *error);
sp_status_t plain_proto_decode_monitor(const sp_can_frame_t *f, sp_msg_monitor_t *m, uint8_t *counter,
                                       sp_proto_error_t *error);
sp_status_t plain_proto_decode_wrench(const sp_can_frame_t *f, sp_msg_wrench_t *m, uint8_t *counter,
                                      sp_proto_error_t *error);

#endif /* PROTOCOL_PLAIN_H */
