/* uart.h -- interrupt-driven UART0 with receive and transmit rings (docs/DESIGN.md §5). */
#ifndef ARTRO_UART_H
#define ARTRO_UART_H

#include <stdint.h>

#define UART_RX_OVERFLOW 0x01u /* the receive ring was full: bytes were lost */
#define UART_RX_ERROR 0x02u    /* framing error or data overrun in the hardware */

void uart_init(void);
/* Next received byte, or -1 if none. */
int16_t uart_getc(void);
uint8_t uart_rx_pending(void);
/* Queue n bytes for sending, all or none; returns 1 if queued. */
uint8_t uart_write(const uint8_t *data, uint8_t n);
/* UART_RX_* flags since the last call. */
uint8_t uart_take_flags(void);

#endif /* ARTRO_UART_H */
