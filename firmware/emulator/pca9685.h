/*
 * An emulated PCA9685 16-channel PWM controller on the AVR's TWI (I2C) bus.
 *
 * Models what the firmware relies on: the register file (MODE1, MODE2, LEDn_ON/OFF at 0x06 + 4n,
 * ALL_LED at 0xFA..0xFD, PRE_SCALE at 0xFE), auto-increment only when MODE1.AI is set, PRE_SCALE
 * writes taking effect only while MODE1.SLEEP is set, no outputs while asleep, full-on / full-off
 * bits, outputs latched on STOP (MODE2.OCH = 0) or on each byte (OCH = 1), register reads.
 * Pulse width = (OFF - ON) mod 4096 ticks of (PRE_SCALE + 1) / 25 MHz.
 *
 * Part of the simavr harness (GPL-3, see README.md): a test tool, not shipped.
 */
#ifndef FS_EMU_PCA9685_H
#define FS_EMU_PCA9685_H

#include <stdint.h>

#include "emu_log.h"
#include "sim_irq.h"

typedef struct {
    avr_t *avr;
    avr_irq_t *irq;
    emu_log_t *log;
    int trace;
    uint8_t address; /* 7-bit */
    uint8_t regs[256];
    int selected;     /* addressed since the last START */
    int got_pointer;  /* the register pointer byte of this write was received */
    uint8_t pointer;
    int pending;      /* registers written since the last latch */
    double width_us[16]; /* last logged widths */
} pca9685_t;

void pca9685_init(pca9685_t *p, avr_t *avr, uint8_t address, emu_log_t *log, int trace);
/* Connect to the AVR's TWI. */
void pca9685_attach(pca9685_t *p, avr_t *avr);

#endif
