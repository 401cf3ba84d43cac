/* uart.c -- UART0, 8N1, interrupt driven: the receive interrupt only stores the byte, so it never
 * delays the TDM guard interrupt by more than a few dozen cycles (docs/DESIGN.md §5). */
#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "config.h"

#define RX_SIZE 128u /* powers of two: the indexes wrap by masking */
#define TX_SIZE 256u

static uint8_t s_rx[RX_SIZE];
static volatile uint8_t s_rx_head, s_rx_tail;
static uint8_t s_tx[TX_SIZE];
static volatile uint8_t s_tx_head, s_tx_tail;
static volatile uint8_t s_flags;

void uart_init(void)
{
    UBRR0H = (uint8_t)(UART_UBRR >> 8);
    UBRR0L = (uint8_t)UART_UBRR;
    UCSR0A = _BV(U2X0);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8 data bits, no parity, 1 stop bit */
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART0_RX_vect)
{
    uint8_t status = UCSR0A;
    uint8_t byte = UDR0;
    if (status & (_BV(FE0) | _BV(DOR0)))
        s_flags |= UART_RX_ERROR;
    uint8_t head = s_rx_head;
    uint8_t next = (uint8_t)((head + 1u) & (RX_SIZE - 1u));
    if (next == s_rx_tail) {
        s_flags |= UART_RX_OVERFLOW;
        return;
    }
    s_rx[head] = byte;
    s_rx_head = next;
}

ISR(USART0_UDRE_vect)
{
    uint8_t tail = s_tx_tail;
    if (tail == s_tx_head) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = s_tx[tail];
    s_tx_tail = (uint8_t)(tail + 1u); /* TX_SIZE = 256: wraps by itself */
}

int16_t uart_getc(void)
{
    uint8_t tail = s_rx_tail;
    if (tail == s_rx_head)
        return -1;
    uint8_t byte = s_rx[tail];
    s_rx_tail = (uint8_t)((tail + 1u) & (RX_SIZE - 1u));
    return byte;
}

uint8_t uart_rx_pending(void)
{
    return s_rx_head != s_rx_tail;
}

uint8_t uart_write(const uint8_t *data, uint8_t n)
{
    uint8_t head = s_tx_head;
    uint8_t used = (uint8_t)(head - s_tx_tail);
    if ((uint16_t)used + n > TX_SIZE - 1u)
        return 0;
    for (uint8_t i = 0; i < n; i++)
        s_tx[(uint8_t)(head + i)] = data[i];
    s_tx_head = (uint8_t)(head + n);
    UCSR0B |= _BV(UDRIE0);
    return 1;
}

uint8_t uart_take_flags(void)
{
    uint8_t flags;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        flags = s_flags;
        s_flags = 0;
    }
    return flags;
}
