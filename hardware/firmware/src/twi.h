/* twi.h -- the one TWI (I²C) master of the firmware, interrupt-driven (docs/BOARDS.md).
 *
 * One transaction at a time, each a register access of one part on the bus: START, SLA+W, the
 * register, then either `write_len` bytes and STOP, or a repeated START, SLA+R, `read_len` bytes
 * (every one acknowledged but the last) and STOP. The parts that share the bus (the MPU-6050,
 * a PCA9685) take turns: a transaction asked for while another runs is refused (TWI_BUSY).
 */
#ifndef ARTRO_TWI_H
#define ARTRO_TWI_H

#include <stdint.h>

enum { TWI_OK = 0, TWI_NACK = 1, TWI_SHORT = 2, TWI_BUSY = 0xFF };

/* Prescaler 1, TWBR from config.h (400 kHz), the TWI on. */
void twi_init(void);
/* Start a transaction to 7-bit `address` at register `reg`: write `write_len` bytes from
 * `data` (0: none), else read `read_len` bytes into `read`. The buffers must live until it ends.
 * Returns TWI_OK if it started, TWI_BUSY if another transaction is still running. */
uint8_t twi_begin(uint8_t address, uint8_t reg, const uint8_t *data, uint8_t write_len,
                  volatile uint8_t *read, uint8_t read_len);
/* TWI_BUSY while the transaction runs, then its result (TWI_OK, TWI_NACK, TWI_SHORT). */
uint8_t twi_result(void);
/* Give up the transaction now (STOP) with `result`, freeing the bus for the next. */
void twi_finish(uint8_t result);
/* A whole transaction, waited for (given up after 2 ms); its result. */
uint8_t twi_blocking(uint8_t address, uint8_t reg, const uint8_t *data, uint8_t write_len,
                     volatile uint8_t *read, uint8_t read_len);

#endif /* ARTRO_TWI_H */
