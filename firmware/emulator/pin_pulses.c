/* Pulse widths on pins D2..D13 in emulated time (see pin_pulses.h). GPL-3 test tool. */
#include "pin_pulses.h"

#include <math.h>
#include <string.h>

#include "avr_ioport.h"

static void on_pin(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    pin_pulses_pin_t *pin = (pin_pulses_pin_t *)param;
    pin_pulses_t *p = pin->owner;
    int ch = pin->channel;
    int level = value != 0;
    if (level == p->level[ch]) {
        return;
    }
    p->level[ch] = level;
    if (level) {
        p->rise[ch] = p->avr->cycle;
        return;
    }
    if (p->rise[ch] == 0) {
        return; /* a fall without a rise seen */
    }
    double width = emu_us(p->avr, p->avr->cycle) - emu_us(p->avr, p->rise[ch]);
    if (fabs(width - p->logged_us[ch]) > p->tolerance_us) {
        p->logged_us[ch] = width;
        emu_log(p->log, p->rise[ch], "pwm", "%d %.3f", ch, width);
    }
}

void pin_pulses_attach(pin_pulses_t *p, avr_t *avr, emu_log_t *log, double tolerance_us)
{
    memset(p, 0, sizeof(*p));
    p->avr = avr;
    p->log = log;
    p->tolerance_us = tolerance_us;
    for (int ch = 0; ch < PIN_PULSES_CHANNELS; ch++) {
        int pin = 2 + ch; /* D2..D7 = PD2..PD7, D8..D13 = PB0..PB5 */
        char port = pin < 8 ? 'D' : 'B';
        int bit = pin < 8 ? pin : pin - 8;
        p->pins[ch].owner = p;
        p->pins[ch].channel = ch;
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit), on_pin,
                                &p->pins[ch]);
    }
}
