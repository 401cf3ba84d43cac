/* twi.c -- the TWI master's state machine, one step per TWI interrupt (twi.h, docs/BOARDS.md). */
#include "twi.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/delay.h>

#include "config.h"

/* TWI status codes (TWSR & 0xF8), master modes */
#define TW_START_SENT 0x08u
#define TW_REP_START_SENT 0x10u
#define TW_SLA_W_ACK 0x18u
#define TW_SLA_W_NACK 0x20u
#define TW_DATA_W_ACK 0x28u
#define TW_DATA_W_NACK 0x30u
#define TW_SLA_R_ACK 0x40u
#define TW_SLA_R_NACK 0x48u
#define TW_DATA_R_ACK 0x50u
#define TW_DATA_R_NACK 0x58u

enum { STEP_START, STEP_SLA_W, STEP_REG, STEP_VALUE, STEP_RESTART, STEP_SLA_R, STEP_DATA };

#define TWCR_GO (_BV(TWINT) | _BV(TWEN) | _BV(TWIE))

static volatile uint8_t s_step, s_result = TWI_OK, s_count;
static uint8_t s_address, s_reg, s_write_len, s_read_len;
static const uint8_t *s_data;
static volatile uint8_t *s_read;

void twi_finish(uint8_t result)
{
    TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN); /* STOP; the interrupt is off until the next */
    s_result = result;
}

ISR(TWI_vect)
{
    const uint8_t status = TWSR & 0xF8u;
    switch (s_step) {
    case STEP_START:
        if (status != TW_START_SENT)
            break;
        TWDR = (uint8_t)(s_address << 1);
        s_step = STEP_SLA_W;
        TWCR = TWCR_GO;
        return;
    case STEP_SLA_W:
        if (status != TW_SLA_W_ACK)
            break;
        TWDR = s_reg;
        s_step = STEP_REG;
        s_count = 0;
        TWCR = TWCR_GO;
        return;
    case STEP_REG:
    case STEP_VALUE:
        if (status != TW_DATA_W_ACK)
            break;
        if (s_write_len) {
            uint8_t n = s_count;
            if (n == s_write_len) {
                twi_finish(TWI_OK);
                return;
            }
            TWDR = s_data[n];
            s_count = (uint8_t)(n + 1u);
            s_step = STEP_VALUE;
            TWCR = TWCR_GO;
        } else {
            s_step = STEP_RESTART;
            TWCR = TWCR_GO | _BV(TWSTA);
        }
        return;
    case STEP_RESTART:
        if (status != TW_REP_START_SENT)
            break;
        TWDR = (uint8_t)((s_address << 1) | 1u);
        s_step = STEP_SLA_R;
        TWCR = TWCR_GO;
        return;
    case STEP_SLA_R:
        if (status != TW_SLA_R_ACK)
            break;
        s_count = 0;
        s_step = STEP_DATA;
        TWCR = s_read_len > 1u ? (uint8_t)(TWCR_GO | _BV(TWEA)) : TWCR_GO; /* ACK all but the last */
        return;
    case STEP_DATA: {
        uint8_t n = s_count;
        const uint8_t last = s_read_len - 1u;
        if (n < last ? status != TW_DATA_R_ACK : status != TW_DATA_R_NACK)
            break;
        s_read[n++] = TWDR;
        s_count = n;
        if (n == s_read_len) {
            twi_finish(TWI_OK);
            return;
        }
        TWCR = n < last ? (uint8_t)(TWCR_GO | _BV(TWEA)) : TWCR_GO;
        return;
    }
    }
    /* anything else: the part did not answer, or the transaction ended early (a bus error, a
     * lost arbitration, a NACK where data should come) */
    const uint8_t nack = status == TW_SLA_W_NACK || status == TW_SLA_R_NACK
        || status == TW_DATA_W_NACK;
    twi_finish(nack ? TWI_NACK : TWI_SHORT);
}

void twi_init(void)
{
    TWSR = 0; /* prescaler 1 */
    TWBR = TWI_TWBR;
    TWCR = _BV(TWEN);
}

uint8_t twi_begin(uint8_t address, uint8_t reg, const uint8_t *data, uint8_t write_len,
                  volatile uint8_t *read, uint8_t read_len)
{
    if (s_result == TWI_BUSY)
        return TWI_BUSY;
    s_address = address;
    s_reg = reg;
    s_data = data;
    s_write_len = write_len;
    s_read = read;
    s_read_len = read_len;
    s_step = STEP_START;
    s_result = TWI_BUSY;
    TWCR = TWCR_GO | _BV(TWSTA);
    return TWI_OK;
}

uint8_t twi_result(void)
{
    return s_result;
}

uint8_t twi_blocking(uint8_t address, uint8_t reg, const uint8_t *data, uint8_t write_len,
                     volatile uint8_t *read, uint8_t read_len)
{
    if (twi_begin(address, reg, data, write_len, read, read_len) != TWI_OK)
        return TWI_BUSY;
    for (uint8_t i = 0; i < 200u && s_result == TWI_BUSY; i++)
        _delay_us(10);
    if (s_result == TWI_BUSY)
        twi_finish(TWI_SHORT);
    return s_result;
}
