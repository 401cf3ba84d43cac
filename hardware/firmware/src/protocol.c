/* protocol.c -- message framing, checking and the commands of PROTOCOL.md (docs/DESIGN.md,
 * Firmware). Runs in the main loop only; the receive interrupt just queues bytes (uart.c). */
#include "protocol.h"

#include <string.h>
#include <util/atomic.h>
#include <util/crc16.h>

#include "artro_schema.h"
#include "artro_wire.h"
#include "config.h"
#include "control.h"
#include "laws.h"
#include "params.h"
#include "sensors.h"
#include "tdm.h"
#include "uart.h"

enum { RX_SYNC, RX_LEN, RX_BODY, RX_CRC_LO, RX_CRC_HI };

static uint8_t s_state = RX_SYNC;
static uint8_t s_len, s_pos, s_crc_lo;
static uint16_t s_crc;
static uint16_t s_last_slot;
static uint8_t s_msg[PROTO_MAX_LEN]; /* TYPE + PAYLOAD */
static uint8_t s_telemetry_on;
static uint8_t s_sticky; /* TELEM_* flags since the last TELEMETRY */

/* ---- sending ------------------------------------------------------------------------------ */

static void send(uint8_t type, const void *payload, uint8_t n)
{
    uint8_t frame[PROTO_MAX_LEN + 4];
    frame[0] = PROTO_SYNC;
    frame[1] = (uint8_t)(n + 1u);
    frame[2] = type;
    memcpy(&frame[3], payload, n);
    uint16_t crc = 0xFFFFu;
    for (uint8_t i = 1; i < n + 3u; i++)
        crc = _crc_xmodem_update(crc, frame[i]);
    frame[n + 3u] = (uint8_t)crc;
    frame[n + 4u] = (uint8_t)(crc >> 8);
    if (!uart_write(frame, (uint8_t)(n + 5u)))
        s_sticky |= TELEM_TX_DROPPED;
}

/* Every payload's layout, and where each field comes from, is declared in
 * hardware/firmware/wire.py, which generates artro_wire.h (PROTOCOL.md's tables too). */

static void send_ack(uint8_t type)
{
    uint8_t p[ARTRO_WIRE_ACK_BYTES];
    wire_pack_ack(p, type);
    send(MSG_ACK, p, sizeof p);
}

static void send_nak(uint8_t type, uint8_t reason, uint8_t detail)
{
    uint8_t p[ARTRO_WIRE_NAK_BYTES];
    wire_pack_nak(p, type, reason, detail);
    send(MSG_NAK, p, sizeof p);
}

static void send_info(void)
{
    uint8_t p[ARTRO_WIRE_INFO_BYTES];
    wire_pack_info(p);
    send(MSG_INFO, p, sizeof p);
}

static void send_telemetry(void)
{
    uint8_t p[ARTRO_WIRE_TELEMETRY_BYTES];
    const plan_t *plan = control_current_plan();
    float phase = gait_phase_rad(plan->phase_acc);
    uint8_t flags = s_sticky;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        if (g_tdm_flags & TDM_OVERRUN)
            flags |= TELEM_OVERRUN;
        if (g_tdm_flags & TDM_SYNC_LOST)
            flags |= TELEM_SYNC_LOST;
        g_tdm_flags = 0;
    }
    if (plan->flags & PLAN_SATURATED)
        flags |= TELEM_SATURATED;
    if (plan->flags & PLAN_GAMMA_CLAMPED)
        flags |= TELEM_GAMMA_CLAMPED;
    wire_pack_telemetry(p, plan, phase, flags);
    s_sticky = 0;
    send(MSG_TELEMETRY, p, sizeof p);
}

static void send_angles(void)
{
    uint8_t p[ARTRO_WIRE_ANGLES_BYTES];
    wire_pack_angles(p, control_current_plan());
    send(MSG_ANGLES, p, sizeof p);
}

static void send_params(uint8_t first, uint8_t count)
{
    uint8_t p[ARTRO_WIRE_PARAMS_MAX_BYTES];
    send(MSG_PARAMS, p, wire_pack_params(p, first, count));
}

static void send_sensors(void)
{
    uint8_t p[ARTRO_WIRE_SENSORS_BYTES];
    wire_pack_sensors(p);
    send(MSG_SENSORS, p, sizeof p);
}

/* ---- commands ----------------------------------------------------------------------------- */

/* Payload length each message type must have; -1 for SET_PARAMS (checked by itself). */
static int16_t expected_length(uint8_t type)
{
    switch (type) {
    case MSG_PING:
    case MSG_START:
    case MSG_STOP:
    case MSG_TORQUE_OFF:
    case MSG_GET_TELEMETRY:
    case MSG_GET_ANGLES:
    case MSG_RESET_PARAMS:
    case MSG_GET_SENSORS:
        return 0;
    case MSG_GET_PARAM:
        return ARTRO_WIRE_GET_PARAM_BYTES;
    case MSG_TELEMETRY_ON:
        return ARTRO_WIRE_TELEMETRY_ON_BYTES;
    case MSG_GET_PARAMS:
        return ARTRO_WIRE_GET_PARAMS_BYTES;
    case MSG_SET_PARAM:
        return ARTRO_WIRE_SET_PARAM_BYTES;
    case MSG_SET_MOTION:
        return ARTRO_WIRE_SET_MOTION_BYTES;
    case MSG_SET_PARAMS:
        return -1;
    default:
        return -2; /* unknown type */
    }
}

static void nak_param(uint8_t type, uint8_t status, uint8_t id)
{
    send_nak(type, status == PARAM_UNKNOWN_ID ? NAK_UNKNOWN_ID : NAK_OUT_OF_RANGE, id);
}

static void dispatch(void)
{
    const uint8_t type = s_msg[0];
    const uint8_t *body = &s_msg[1];
    const uint8_t n = (uint8_t)(s_len - 1u);
    int16_t expected = expected_length(type);
    if (expected == -2) {
        send_nak(type, NAK_UNKNOWN_TYPE, 0);
        return;
    }
    if (expected >= 0 && n != expected) {
        send_nak(type, NAK_BAD_LENGTH, n);
        return;
    }

    float values[PROTO_MAX_VALUES];
    uint8_t status, bad, id, first, count, mode;
    switch (type) {
    case MSG_PING:
        send_info();
        break;
    case MSG_SET_MOTION:
        wire_unpack_set_motion(body, values);
        status = params_set_many(ARTRO_PID_MOTION_A_R, 4, values, &bad);
        if (status != PARAM_OK)
            nak_param(type, status, bad);
        else
            send_ack(type);
        break;
    case MSG_SET_PARAM:
        wire_unpack_set_param(body, &id, &values[0]);
        status = params_set(id, values[0]);
        if (status != PARAM_OK)
            nak_param(type, status, id);
        else
            send_ack(type);
        break;
    case MSG_SET_PARAMS:
        count = n >= ARTRO_WIRE_SET_PARAMS_BYTES ? body[ARTRO_WIRE_SET_PARAMS_COUNT] : 0;
        if (n < ARTRO_WIRE_SET_PARAMS_BYTES || count == 0 || count > PROTO_MAX_VALUES
            || n != ARTRO_WIRE_SET_PARAMS_BYTES_OF(count)) {
            send_nak(type, NAK_BAD_LENGTH, n);
            break;
        }
        wire_unpack_set_params(body, &first, &count, values);
        status = params_set_many(first, count, values, &bad);
        if (status != PARAM_OK)
            nak_param(type, status, bad);
        else
            send_ack(type);
        break;
    case MSG_GET_PARAM:
        wire_unpack_get_param(body, &id);
        if (id >= ARTRO_PARAM_COUNT) {
            send_nak(type, NAK_UNKNOWN_ID, id);
        } else {
            uint8_t p[ARTRO_WIRE_PARAM_BYTES];
            wire_pack_param(p, id);
            send(MSG_PARAM, p, sizeof p);
        }
        break;
    case MSG_GET_PARAMS:
        wire_unpack_get_params(body, &first, &count);
        if (count == 0 || count > PROTO_MAX_VALUES) {
            send_nak(type, NAK_OUT_OF_RANGE, count);
        } else if ((uint16_t)first + count > ARTRO_PARAM_COUNT) {
            /* the first id of the range that does not exist, as SET_PARAMS names it */
            send_nak(type, NAK_UNKNOWN_ID, first > ARTRO_PARAM_COUNT ? first : ARTRO_PARAM_COUNT);
        } else {
            send_params(first, count);
        }
        break;
    case MSG_START:
    case MSG_STOP:
    case MSG_TORQUE_OFF:
        control_set_state(type == MSG_START ? RUN_WALK : type == MSG_STOP ? RUN_STOP : RUN_TORQUE_OFF);
        send_ack(type);
        break;
    case MSG_TELEMETRY_ON:
        wire_unpack_telemetry_on(body, &mode);
        if (mode > 2) {
            send_nak(type, NAK_OUT_OF_RANGE, mode);
            break;
        }
        s_telemetry_on = mode;
        send_ack(type);
        break;
    case MSG_GET_TELEMETRY:
        send_telemetry();
        break;
    case MSG_GET_ANGLES:
        send_angles();
        break;
    case MSG_GET_SENSORS:
        send_sensors();
        break;
    case MSG_RESET_PARAMS:
        params_reset();
        send_ack(type);
        break;
    }
}

/* ---- receiving ---------------------------------------------------------------------------- */

static void receive(uint8_t byte)
{
    switch (s_state) {
    case RX_SYNC:
        if (byte == PROTO_SYNC)
            s_state = RX_LEN;
        break; /* anything else between messages is line noise: skipped */
    case RX_LEN:
        if (byte == PROTO_SYNC)
            break; /* a LEN of 165 is no message's (PROTOCOL.md): the sync before was noise */
        if (byte == 0 || byte > PROTO_MAX_LEN) {
            send_nak(0, NAK_BAD_LENGTH, byte);
            s_state = RX_SYNC;
            break;
        }
        s_len = byte;
        s_pos = 0;
        s_crc = _crc_xmodem_update(0xFFFFu, byte);
        s_state = RX_BODY;
        break;
    case RX_BODY:
        s_msg[s_pos++] = byte;
        s_crc = _crc_xmodem_update(s_crc, byte);
        if (s_pos == s_len)
            s_state = RX_CRC_LO;
        break;
    case RX_CRC_LO:
        s_crc_lo = byte;
        s_state = RX_CRC_HI;
        break;
    case RX_CRC_HI:
        s_state = RX_SYNC;
        if ((uint16_t)(s_crc_lo | (uint16_t)byte << 8) != s_crc)
            send_nak(s_msg[0], NAK_BAD_CRC, 0);
        else
            dispatch();
        break;
    }
}

void protocol_poll(void)
{
    int16_t byte;
    uint16_t now;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        now = g_slot_count;
    }
    uint8_t uart_flags = uart_take_flags();
    if (uart_flags)
        s_sticky |= TELEM_RX_ERROR;
    if (uart_flags & UART_RX_OVERFLOW) {
        if (s_state != RX_SYNC)
            send_nak(s_state >= RX_BODY && s_pos > 0 ? s_msg[0] : 0, NAK_RX_OVERFLOW, 0);
        s_state = RX_SYNC; /* the message lost bytes: drop it */
    }
    while ((byte = uart_getc()) >= 0) {
        receive((uint8_t)byte);
        s_last_slot = now;
    }
    if (s_state != RX_SYNC && (uint16_t)(now - s_last_slot) >= RX_TIMEOUT_SLOTS) {
        send_nak(s_state >= RX_BODY && s_pos > 0 ? s_msg[0] : 0, NAK_TIMEOUT, 0);
        s_state = RX_SYNC;
    }
}

void protocol_frame(void)
{
    if (s_telemetry_on == 1)
        send_telemetry();
    else if (s_telemetry_on == 2)
        send_sensors();
}
