/* An emulated PCA9685 on the AVR's TWI bus (see pca9685.h). GPL-3 test tool, see README.md. */
#include "pca9685.h"

#include <math.h>
#include <string.h>

#include "avr_twi.h"
#include "sim_avr.h"

enum {
    REG_MODE1 = 0x00,
    REG_MODE2 = 0x01,
    REG_LED0 = 0x06,
    REG_LED15_END = 0x45,
    REG_ALL_LED = 0xFA,
    REG_ALL_LED_END = 0xFD,
    REG_PRE_SCALE = 0xFE,
    MODE1_RESTART = 0x80,
    MODE1_AI = 0x20,
    MODE1_SLEEP = 0x10,
    MODE2_OCH = 0x08,
    FULL_BIT = 0x10, /* bit 4 of LEDn_ON_H / LEDn_OFF_H */
};

static double channel_width(const pca9685_t *p, int ch)
{
    const uint8_t *r = p->regs + REG_LED0 + 4 * ch;
    if ((p->regs[REG_MODE1] & MODE1_SLEEP) || (r[3] & FULL_BIT)) {
        return 0.0; /* oscillator off, or full off (which wins over full on) */
    }
    double tick_us = (p->regs[REG_PRE_SCALE] + 1) / 25.0;
    if (r[1] & FULL_BIT) {
        return 4096 * tick_us;
    }
    unsigned on = r[0] | ((r[1] & 0x0F) << 8);
    unsigned off = r[2] | ((r[3] & 0x0F) << 8);
    return ((off - on) & 0x0FFF) * tick_us;
}

/* Outputs take the new register values: log every channel whose width changed. */
static void latch(pca9685_t *p)
{
    p->pending = 0;
    for (int ch = 0; ch < 16; ch++) {
        double w = channel_width(p, ch);
        if (fabs(w - p->width_us[ch]) > 1e-9) {
            p->width_us[ch] = w;
            emu_log(p->log, p->avr->cycle, "pwm", "%d %.3f", ch, w);
        }
    }
}

static void write_register(pca9685_t *p, uint8_t reg, uint8_t value)
{
    if (reg == REG_PRE_SCALE) {
        if (!(p->regs[REG_MODE1] & MODE1_SLEEP)) {
            emu_log(p->log, p->avr->cycle, "warn", "PRE_SCALE write 0x%02x ignored: not asleep", value);
            return;
        }
        p->regs[reg] = value < 3 ? 3 : value;
        emu_log(p->log, p->avr->cycle, "reg", "PRE_SCALE 0x%02x", p->regs[reg]);
    } else if (reg == REG_MODE1 || reg == REG_MODE2) {
        p->regs[reg] = reg == REG_MODE1 ? (uint8_t)(value & ~MODE1_RESTART) : value;
        emu_log(p->log, p->avr->cycle, "reg", "%s 0x%02x", reg == REG_MODE1 ? "MODE1" : "MODE2",
                value);
    } else if (reg >= REG_LED0 && reg <= REG_LED15_END) {
        p->regs[reg] = value;
    } else if (reg >= REG_ALL_LED && reg <= REG_ALL_LED_END) {
        p->regs[reg] = value;
        for (int ch = 0; ch < 16; ch++) {
            p->regs[REG_LED0 + 4 * ch + (reg - REG_ALL_LED)] = value;
        }
    } else {
        emu_log(p->log, p->avr->cycle, "warn", "write 0x%02x to reserved register 0x%02x", value, reg);
        return;
    }
    p->pending = 1;
}

static void advance_pointer(pca9685_t *p)
{
    if (!(p->regs[REG_MODE1] & MODE1_AI)) {
        return; /* without auto-increment every byte goes to the same register */
    }
    if (p->pointer == REG_LED15_END || p->pointer == REG_ALL_LED_END || p->pointer == REG_PRE_SCALE) {
        p->pointer = REG_MODE1;
    } else {
        p->pointer++;
    }
}

static void reply(pca9685_t *p, uint8_t msg, uint8_t addr, uint8_t data)
{
    avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(msg, addr, data));
}

static void on_twi(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    pca9685_t *p = (pca9685_t *)param;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    uint8_t msg = v.u.twi.msg, addr = v.u.twi.addr, data = v.u.twi.data;

    if (msg & TWI_COND_STOP) {
        if (p->selected) {
            if (p->trace) {
                emu_log(p->log, p->avr->cycle, "i2c", "stop");
            }
            if (p->pending) {
                latch(p);
            }
        }
        p->selected = 0;
    }
    if (msg & TWI_COND_START) {
        p->selected = (addr >> 1) == p->address;
        p->got_pointer = 0;
        if (p->selected) {
            if (p->trace) {
                emu_log(p->log, p->avr->cycle, "i2c", "start %s", (addr & 1) ? "read" : "write");
            }
            reply(p, TWI_COND_ACK, addr, 1);
        }
    }
    if (!p->selected) {
        return;
    }
    if (msg & TWI_COND_WRITE) {
        reply(p, TWI_COND_ACK, addr, 1);
        if (p->trace) {
            emu_log(p->log, p->avr->cycle, "i2c", "write 0x%02x", data);
        }
        if (!p->got_pointer) {
            p->pointer = data;
            p->got_pointer = 1;
        } else {
            write_register(p, p->pointer, data);
            advance_pointer(p);
            if ((p->regs[REG_MODE2] & MODE2_OCH) && p->pending) {
                latch(p); /* OCH = 1: outputs change on ACK */
            }
        }
    }
    if (msg & TWI_COND_READ) {
        uint8_t out = p->regs[p->pointer];
        if (p->trace) {
            emu_log(p->log, p->avr->cycle, "i2c", "read 0x%02x", out);
        }
        reply(p, TWI_COND_READ, addr, out);
        advance_pointer(p);
    }
}

void pca9685_init(pca9685_t *p, avr_t *avr, uint8_t address, emu_log_t *log, int trace)
{
    static const char *names[2] = {"8>pca9685.out", "32<pca9685.in"};
    memset(p, 0, sizeof(*p));
    p->avr = avr;
    p->log = log;
    p->trace = trace;
    p->address = address;
    /* Power-on values (datasheet): asleep, ALLCALL, 200 Hz, every channel full off. */
    p->regs[REG_MODE1] = 0x11;
    p->regs[REG_MODE2] = 0x04;
    p->regs[REG_PRE_SCALE] = 0x1E;
    for (int ch = 0; ch < 16; ch++) {
        p->regs[REG_LED0 + 4 * ch + 3] = FULL_BIT;
    }
    p->irq = avr_alloc_irq(&avr->irq_pool, 0, 2, names);
    avr_irq_register_notify(p->irq + TWI_IRQ_OUTPUT, on_twi, p);
}

void pca9685_attach(pca9685_t *p, avr_t *avr)
{
    avr_connect_irq(p->irq + TWI_IRQ_INPUT,
                    avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT));
    avr_connect_irq(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT),
                    p->irq + TWI_IRQ_OUTPUT);
}
