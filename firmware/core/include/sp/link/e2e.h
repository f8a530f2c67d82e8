/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/link/e2e.h - end-to-end protection of safety-relevant CAN frames, in the
 * pattern of the AUTOSAR E2E profiles (protocol/stewart.dbc, docs/reference/protocol.md):
 *
 *  - a 4-bit alive counter (signal Counter), +1 mod 16 per transmission;
 *  - a CRC in the frame's last byte(s): CRC-8 SAE J1850 (poly 0x1D, init and
 *    xorout 0xFF) for frames of at most 12 bytes, CRC-16/CCITT-FALSE (poly
 *    0x1021, init 0xFFFF) above. It covers the 11-bit CAN identifier as two
 *    bytes, little-endian (the data ID: a frame on the wrong identifier fails),
 *    then every payload byte before the CRC.
 *
 * Receivers classify each counter: delta 1 ok; 2..SP_E2E_MAX_DELTA ok with
 * frames lost; 0 repeated (rejected); larger: wrong sequence (rejected, and the
 * next frame resynchronises).
 */
#ifndef SP_E2E_H
#define SP_E2E_H

#include <stdint.h>

#include "sp/link/can.h"
#include "sp/math/status.h"

#define SP_E2E_MAX_DELTA 3u
#define SP_E2E_CRC16_ABOVE 12u /**< frames longer than this carry a CRC-16 */

/** CRC-8 SAE J1850 of data[0..n) (check value of "123456789": 0x4B). */
uint8_t sp_crc8_j1850(const uint8_t *data, uint32_t n);

/** CRC-16/CCITT-FALSE of data[0..n) (check value of "123456789": 0x29B1). */
uint16_t sp_crc16_ccitt(const uint8_t *data, uint32_t n);

/** The frame's E2E CRC over its data ID and payload (len must be >= the CRC
 *  size). Returns 0 for a NULL frame. */
uint16_t sp_e2e_crc(const sp_can_frame_t *frame);

/** Writes the CRC into the frame's last byte(s). SP_E_ARG if len < 2. */
sp_status_t sp_e2e_seal(sp_can_frame_t *frame);

/** SP_OK if the CRC in the last byte(s) matches, SP_E_FRAME otherwise. */
sp_status_t sp_e2e_check_crc(const sp_can_frame_t *frame);

typedef enum {
    SP_E2E_OK = 0,       /**< next in sequence */
    SP_E2E_OK_LOST = 1,  /**< accepted; 1..SP_E2E_MAX_DELTA-1 frames were lost */
    SP_E2E_INITIAL = 2,  /**< first frame after start or a resynchronisation */
    SP_E2E_REPEATED = 3, /**< same counter as the last accepted frame: rejected */
    SP_E2E_WRONG_SEQ = 4 /**< counter jumped too far: rejected, resynchronising */
} sp_e2e_result_t;

/** Receiver state of one message from one sender. Zero-initialise it. */
typedef struct {
    uint8_t synced; /**< 1 once a frame was accepted */
    uint8_t last;   /**< counter of the last accepted frame */
} sp_e2e_rx_t;

/** Classifies a received counter (0..15) and updates the state: accepted
 *  results (OK, OK_LOST, INITIAL) remember it; WRONG_SEQ drops the sync so
 *  that the next frame is INITIAL; REPEATED changes nothing. */
sp_e2e_result_t sp_e2e_rx_check(sp_e2e_rx_t *rx, uint8_t counter);

/** 1 for the results whose frame may be used. */
int sp_e2e_accepted(sp_e2e_result_t r);

#endif /* SP_E2E_H */
