/*
 * Event log of the facesynth emulator harness: one line per event, stamped with the emulated
 * time in microseconds (avr->cycle / 16 MHz), never wall time.
 *
 *   pwm <t_us> <channel> <width_us>   a channel's pulse width changed (0 = no pulses)
 *   rx <t_us> <hex byte>              a byte from the host is complete in the AVR's UART
 *   tx <t_us> <hex byte>              the AVR wrote a byte to its UART
 *   reg <t_us> <name> <hex value>     PCA9685 MODE1 / MODE2 / PRE_SCALE written
 *   i2c <t_us> <event>                with --trace-i2c: start / write / read / stop
 *   warn <t_us> <text>                something a real part would not accept
 *   stack <t_us> <used> <untouched>   with --stack-from: deepest stack use, bytes (at the end)
 *   end <t_us> stopped|crashed        the harness stopped
 *
 * Part of the simavr harness (GPL-3, see README.md): a test tool, not shipped.
 */
#ifndef FS_EMU_LOG_H
#define FS_EMU_LOG_H

#include <stdio.h>

#include "sim_avr.h"

typedef struct {
    avr_t *avr;
    FILE *out;
} emu_log_t;

/* Write "<kind> <t_us> <formatted text>\n" stamped at the given cycle. */
void emu_log(emu_log_t *log, avr_cycle_count_t cycle, const char *kind, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
double emu_us(const avr_t *avr, avr_cycle_count_t cycle);

#endif
