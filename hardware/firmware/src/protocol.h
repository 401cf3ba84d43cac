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

/* The message types (MSG_PING, ...) and every payload's layout: artro_wire.h, generated from
 * hardware/firmware/wire.py (PROTOCOL.md's tables too). */

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
