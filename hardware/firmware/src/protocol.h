/* protocol.h -- the framed, checksummed UART protocol (see ../PROTOCOL.md; docs/DESIGN.md §5).
 *
 *   0xA5 | LEN | TYPE | PAYLOAD (LEN - 1 bytes) | CRC16 low | CRC16 high
 *
 * CRC-16/CCITT-FALSE (polynomial 0x1021, initial 0xFFFF) over LEN, TYPE and PAYLOAD. Numbers are
 * little-endian; values are IEEE-754 float32. Every host message is answered (ACK, NAK or the data
 * asked for); a bad message gets a NAK with a reason and changes nothing.
 */
#ifndef ARTRO_PROTOCOL_H
#define ARTRO_PROTOCOL_H

#include <stdint.h>

#define PROTO_SYNC 0xA5u
#define PROTO_VERSION 2u
#define PROTO_MAX_LEN 200u /* TYPE + PAYLOAD */
#define PROTO_MAX_VALUES 48u /* values in one SET_PARAMS or PARAMS: 3 + 4 * 48 <= 200 */

/* host -> robot */
enum {
    MSG_PING = 0x01,          /* -> INFO */
    MSG_SET_MOTION = 0x02,    /* a_r, a_p, a_y, ca: 4 x f32 -> ACK */
    MSG_SET_PARAM = 0x03,     /* id u8, value f32 -> ACK */
    MSG_SET_PARAMS = 0x04,    /* first u8, count u8 (1..48), count x f32 -> ACK */
    MSG_GET_PARAM = 0x05,     /* id u8 -> PARAM */
    MSG_GET_PARAMS = 0x06,    /* first u8, count u8 (1..48) -> PARAMS */
    MSG_START = 0x07,         /* walk (torque on) -> ACK */
    MSG_STOP = 0x08,          /* hold the pose, clock stopped -> ACK */
    MSG_TORQUE_OFF = 0x09,    /* no pulses -> ACK */
    MSG_TELEMETRY_ON = 0x0A,  /* mode u8: 0 off, 1 TELEMETRY, 2 SENSORS every frame -> ACK */
    MSG_GET_TELEMETRY = 0x0B, /* -> TELEMETRY */
    MSG_GET_ANGLES = 0x0C,    /* -> ANGLES */
    MSG_RESET_PARAMS = 0x0D,  /* back to the compiled-in parameter set -> ACK */
    MSG_GET_SENSORS = 0x0E,   /* -> SENSORS */
};

/* robot -> host */
enum {
    MSG_ACK = 0x81,       /* type u8, effective frame u32 */
    MSG_NAK = 0x82,       /* type u8, reason u8, detail u8 */
    MSG_INFO = 0x83,      /* version u8, param count u8, schema hash u32, frame u32, state u8 */
    MSG_PARAM = 0x84,     /* id u8, value f32 */
    MSG_PARAMS = 0x85,    /* first u8, count u8, count x f32 */
    MSG_TELEMETRY = 0x86, /* frame u32, phase f32, ocr 12 x u16, saturated u16, flags u8, state u8 */
    MSG_ANGLES = 0x87,    /* frame u32, 12 x f32 */
    MSG_SENSORS = 0x88,   /* the balance sensors and laws of the frame planned last: PROTOCOL.md */
};

/* NAK reasons */
enum {
    NAK_BAD_CRC = 1,
    NAK_UNKNOWN_TYPE = 2,
    NAK_BAD_LENGTH = 3,
    NAK_UNKNOWN_ID = 4,
    NAK_OUT_OF_RANGE = 5,
    NAK_TIMEOUT = 6,
    NAK_RX_OVERFLOW = 7,
};

/* TELEMETRY flags */
#define TELEM_SATURATED 0x01u
#define TELEM_GAMMA_CLAMPED 0x02u
#define TELEM_OVERRUN 0x04u
#define TELEM_SYNC_LOST 0x08u
#define TELEM_RX_ERROR 0x10u
#define TELEM_TX_DROPPED 0x20u

/* Process received bytes; call from the main loop. */
void protocol_poll(void);
/* Once per frame: send TELEMETRY if it is switched on. */
void protocol_frame(void);

#endif /* ARTRO_PROTOCOL_H */
