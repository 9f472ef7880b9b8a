/*
 * Pulse widths on the Uno's pins D2..D13 (channels 0..11 of the firmware's pins mode), timed
 * with the emulated cycle counter. A width is logged ("pwm") when it differs from the last one
 * logged for that channel by more than the tolerance (interrupt latency makes software pulses
 * jitter by a few microseconds).
 *
 * Part of the simavr harness (GPL-3, see README.md): a test tool, not shipped.
 */
#ifndef FS_EMU_PIN_PULSES_H
#define FS_EMU_PIN_PULSES_H

#include "emu_log.h"
#include "sim_avr.h"

#define PIN_PULSES_CHANNELS 12

typedef struct pin_pulses pin_pulses_t;

typedef struct {
    pin_pulses_t *owner;
    int channel;
} pin_pulses_pin_t;

struct pin_pulses {
    avr_t *avr;
    emu_log_t *log;
    double tolerance_us;
    pin_pulses_pin_t pins[PIN_PULSES_CHANNELS];
    int level[PIN_PULSES_CHANNELS];
    avr_cycle_count_t rise[PIN_PULSES_CHANNELS];
    double logged_us[PIN_PULSES_CHANNELS];
};

void pin_pulses_attach(pin_pulses_t *p, avr_t *avr, emu_log_t *log, double tolerance_us);

#endif
