/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/link/e2e.h"

uint8_t sp_crc8_j1850(const uint8_t *data, uint32_t n)
{
    uint8_t crc = 0xFFu;
    if (data == NULL) {
        return 0u;
    }
    for (uint32_t i = 0; i < n; i++) {
        crc = (uint8_t)(crc ^ data[i]);
        for (uint32_t b = 0; b < 8u; b++) {
            uint32_t shifted = ((uint32_t)crc << 1) ^ ((crc & 0x80u) ? 0x1Du : 0u);
            crc = (uint8_t)(shifted & 0xFFu);
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

uint16_t sp_crc16_ccitt(const uint8_t *data, uint32_t n)
{
    uint16_t crc = 0xFFFFu;
    if (data == NULL) {
        return 0u;
    }
    for (uint32_t i = 0; i < n; i++) {
        crc = (uint16_t)(crc ^ (uint16_t)((uint16_t)data[i] << 8));
        for (uint32_t b = 0; b < 8u; b++) {
            uint32_t shifted = ((uint32_t)crc << 1) ^ ((crc & 0x8000u) ? 0x1021u : 0u);
            crc = (uint16_t)(shifted & 0xFFFFu);
        }
    }
    return crc;
}

static uint32_t crc_size(const sp_can_frame_t *f)
{
    return f->len > SP_E2E_CRC16_ABOVE ? 2u : 1u;
}

uint16_t sp_e2e_crc(const sp_can_frame_t *frame)
{
    uint8_t buf[2u + SP_CAN_MAX_DATA];
    if (frame == NULL || frame->len < 2u || frame->len > SP_CAN_MAX_DATA) {
        return 0u;
    }
    uint32_t n = frame->len - crc_size(frame);
    buf[0] = (uint8_t)(frame->id & 0xFFu);
    buf[1] = (uint8_t)((frame->id >> 8) & 0x07u);
    for (uint32_t i = 0; i < n; i++) {
        buf[2u + i] = frame->data[i];
    }
    if (crc_size(frame) == 2u) {
        return sp_crc16_ccitt(buf, n + 2u);
    }
    return sp_crc8_j1850(buf, n + 2u);
}

sp_status_t sp_e2e_seal(sp_can_frame_t *frame)
{
    if (frame == NULL || frame->len < 2u || frame->len > SP_CAN_MAX_DATA) {
        return SP_E_ARG;
    }
    uint16_t crc = sp_e2e_crc(frame);
    if (crc_size(frame) == 2u) {
        frame->data[frame->len - 2u] = (uint8_t)(crc & 0xFFu);
        frame->data[frame->len - 1u] = (uint8_t)(crc >> 8);
    } else {
        frame->data[frame->len - 1u] = (uint8_t)crc;
    }
    return SP_OK;
}

sp_status_t sp_e2e_check_crc(const sp_can_frame_t *frame)
{
    if (frame == NULL || frame->len < 2u || frame->len > SP_CAN_MAX_DATA) {
        return SP_E_FRAME;
    }
    uint16_t crc = sp_e2e_crc(frame);
    uint16_t got;
    if (crc_size(frame) == 2u) {
        got = (uint16_t)(frame->data[frame->len - 2u] | (uint16_t)(frame->data[frame->len - 1u] << 8));
    } else {
        got = frame->data[frame->len - 1u];
    }
    return got == crc ? SP_OK : SP_E_FRAME;
}

sp_e2e_result_t sp_e2e_rx_check(sp_e2e_rx_t *rx, uint8_t counter)
{
    if (rx == NULL) {
        return SP_E2E_WRONG_SEQ;
    }
    counter &= 0x0Fu;
    if (!rx->synced) {
        rx->synced = 1u;
        rx->last = counter;
        return SP_E2E_INITIAL;
    }
    uint8_t delta = (uint8_t)((counter - rx->last) & 0x0Fu);
    if (delta == 0u) {
        return SP_E2E_REPEATED;
    }
    if (delta > SP_E2E_MAX_DELTA) {
        rx->synced = 0u;
        return SP_E2E_WRONG_SEQ;
    }
    rx->last = counter;
    return delta == 1u ? SP_E2E_OK : SP_E2E_OK_LOST;
}

int sp_e2e_accepted(sp_e2e_result_t r)
{
    return r == SP_E2E_OK || r == SP_E2E_OK_LOST || r == SP_E2E_INITIAL;
}
