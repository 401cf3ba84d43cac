/* harness_fixes.c -- the simavr harness's corrections of simavr's timer and UART models (the
 * harness_t of harness.h; artro_mcu_new of harness.c applies them). docs/DESIGN.md §5.
 *
 * Three corrections of simavr's timer models, each can be left out to show what it does:
 *  - FIX_MODE14: simavr maps waveform mode 14 of Timer1/Timer3 to phase-correct PWM on this core,
 *    which ignores OCR writes (upstream issue buserror/simavr#579); the table entry is set to
 *    fast PWM with TOP = ICRn.
 *  - FIX_OCR_HIGH_BYTE: in PWM modes simavr takes a new OCRnx only if the 16-bit value differs
 *    once the low byte is written, comparing with the high byte already stored -- so a change of
 *    the high byte alone is lost. On the chip the high byte waits in TEMP and both bytes change
 *    together; the harness makes simavr see such a write as the change it is.
 *  - FIX_UART_BYTE_TIME: simavr times a UART byte when UBRRnL is written, with the U2Xn bit of
 *    that moment and always a parity bit. The firmware sets U2X0 after the rate, as the
 *    datasheet allows, and sends no parity: 57600 baud became 26 182 (11 bits of 32 us), so a
 *    walk's SENSORS stream lost one frame in three. The byte time is recomputed after every
 *    write to the UART's rate and control registers, as the chip's baud generator has it.
 */
#include <stdint.h>
#include <string.h>

#include <simavr/avr_timer.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>

#include "harness.h"

/* FIX_UART_BYTE_TIME: a byte is a start bit, the data bits, a parity bit if UPMn1:0 ask for
 * one and the stop bits, each (UBRRn + 1) * 16 cycles, or * 8 with U2Xn. */
static void uart_byte_time(avr_t *avr, avr_uart_t *uart)
{
    static const uint8_t data_bits[8] = {5, 6, 7, 8, 8, 8, 8, 9};
    uint32_t ubrr = avr_regbit_get(avr, uart->ubrrl) | (avr_regbit_get(avr, uart->ubrrh) << 8);
    uint8_t size = avr_regbit_get(avr, uart->ucsz) | (avr_regbit_get(avr, uart->ucsz2) << 2);
    uint8_t parity = (avr->data[uart->r_ucsrc] & 0x30) ? 1 : 0; /* UPMn1:0, bits 5:4 */
    uint8_t stop = 1 + avr_regbit_get(avr, uart->usbs);
    uint32_t per_bit = (ubrr + 1) * (avr_regbit_get(avr, uart->u2x) ? 8u : 16u);
    uart->cycles_per_byte = per_bit * (1u + data_bits[size] + parity + stop);
}

/* after simavr's own handler of the register (which stores the byte) */
static void uart_config_written(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)addr;
    (void)v;
    uart_byte_time(avr, param);
}

/* a register simavr does not watch: the byte stored here, as the core would */
static void uart_config_stored(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    avr_core_watch_write(avr, addr, v);
    uart_byte_time(avr, param);
}

int fix_uart_byte_time(avr_t *avr)
{
    avr_uart_t *uart = NULL;
    for (avr_io_t *io = avr->io_port; io; io = io->next)
        if (io->kind && strcmp(io->kind, "uart") == 0 && ((avr_uart_t *)io)->name == '0')
            uart = (avr_uart_t *)io; /* avr_io_t is its first member */
    if (!uart)
        return -1;
    const avr_io_addr_t regs[] = {uart->ubrrl.reg, uart->ubrrh.reg, uart->r_ucsra,
                                  uart->r_ucsrb, uart->r_ucsrc};
    for (size_t i = 0; i < sizeof regs / sizeof regs[0]; i++) {
        avr_io_addr_t io = AVR_DATA_TO_IO(regs[i]);
        int watched = avr->io[io].w.c != NULL;
        avr_register_io_write(avr, regs[i], watched ? uart_config_written : uart_config_stored,
                              uart);
    }
    return 0;
}

static void ocr_low_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    ocr_wrap_t *w = param;
    uint8_t high = avr->data[w->high];
    if (avr->data[addr] == v && high != w->last_high)
        avr->data[addr] = (uint8_t)~v; /* let simavr see the 16-bit value change */
    w->last_high = high;
    w->write(avr, addr, v, w->param);
}

void wrap_ocr_writes(harness_t *h)
{
    avr_timer_t *timers[2] = {h->timer1, h->timer3};
    for (int t = 0; t < 2; t++) {
        for (int c = 0; c < 3; c++) {
            avr_timer_comp_t *comp = &timers[t]->comp[c];
            ocr_wrap_t *w = &h->ocr[3 * t + c];
            avr_io_addr_t io = AVR_DATA_TO_IO(comp->r_ocr);
            w->write = h->avr->io[io].w.c;
            w->param = h->avr->io[io].w.param;
            w->high = comp->r_ocrh;
            w->last_high = h->avr->data[comp->r_ocrh];
            h->avr->io[io].w.c = ocr_low_write;
            h->avr->io[io].w.param = w;
        }
    }
}

/* FIX_MODE14: waveform mode 14 of Timer1 and Timer3 as the chip has it */
void fix_mode14(harness_t *h)
{
    /* mode 14 = WGMn3:0 1110: fast PWM, TOP = ICRn, OCRnx taken at the period end */
    const avr_timer_wgm_t fast_pwm_icr = AVR_TIMER_WGM_ICFASTPWM();
    h->timer1->wgm_op[14] = fast_pwm_icr;
    h->timer3->wgm_op[14] = fast_pwm_icr;
}
