/* UART0 <-> pseudo-terminal, paced in emulated time (see pty_bridge.h). GPL-3 test tool. */
#define _GNU_SOURCE
#include "pty_bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "avr_uart.h"
#include "sim_cycle_timers.h"
#include "sim_io.h"
#include "sim_time.h"

/* While the host is silent, look at the pty this often (emulated microseconds). */
#define IDLE_POLL_US 100

static struct avr_uart_t *find_uart0(avr_t *avr)
{
    for (avr_io_t *io = avr->io_port; io != NULL; io = io->next) {
        if (io->kind != NULL && strcmp(io->kind, "uart") == 0 && ((avr_uart_t *)io)->name == '0') {
            return (avr_uart_t *)io;
        }
    }
    return NULL;
}

static void on_tx(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    pty_bridge_t *b = (pty_bridge_t *)param;
    uint8_t byte = (uint8_t)value;
    emu_log(b->log, b->avr->cycle, "tx", "%02x", byte);
    if (write(b->master, &byte, 1) != 1) {
        b->tx_dropped++;
    }
}

static void on_xon(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    if (value) {
        ((pty_bridge_t *)param)->xoff = 0;
    }
}

static void on_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    ((pty_bridge_t *)param)->xoff = value != 0;
}

static avr_cycle_count_t poll_host(avr_t *avr, avr_cycle_count_t when, void *param)
{
    pty_bridge_t *b = (pty_bridge_t *)param;
    avr_cycle_count_t idle = avr_usec_to_cycles(avr, IDLE_POLL_US);
    if (b->len == 0) {
        ssize_t n = read(b->master, b->pending, sizeof(b->pending));
        if (n <= 0) {
            return when + idle;
        }
        b->head = 0;
        b->len = (size_t)n;
    }
    avr_cycle_count_t byte_time = b->uart->cycles_per_byte;
    if (byte_time == 0 || b->xoff) {
        return when + idle; /* UART not configured yet, or its input is full */
    }
    if (when < b->next_rx) {
        return b->next_rx;
    }
    uint8_t byte = b->pending[b->head++];
    b->len--;
    avr_raise_irq(b->uart_in, byte);
    /* The UART raises RXC one byte time later: that is when the byte is complete. */
    emu_log(b->log, when + byte_time, "rx", "%02x", byte);
    b->next_rx = when + byte_time;
    return b->next_rx;
}

int pty_bridge_init(pty_bridge_t *b, avr_t *avr, const char *link, emu_log_t *log)
{
    memset(b, 0, sizeof(*b));
    b->avr = avr;
    b->log = log;
    b->master = posix_openpt(O_RDWR | O_NOCTTY);
    if (b->master < 0 || grantpt(b->master) != 0 || unlockpt(b->master) != 0) {
        fprintf(stderr, "fs_emulator: cannot open a pty: %s\n", strerror(errno));
        return -1;
    }
    snprintf(b->slave_name, sizeof(b->slave_name), "%s", ptsname(b->master));
    b->slave = open(b->slave_name, O_RDWR | O_NOCTTY);
    struct termios tio;
    if (b->slave < 0 || tcgetattr(b->slave, &tio) != 0) {
        fprintf(stderr, "fs_emulator: cannot open %s: %s\n", b->slave_name, strerror(errno));
        return -1;
    }
    cfmakeraw(&tio); /* binary frames: no echo, no CR/LF translation */
    tcsetattr(b->slave, TCSANOW, &tio);
    fcntl(b->master, F_SETFL, fcntl(b->master, F_GETFL) | O_NONBLOCK);
    if (link != NULL) {
        if (symlink(b->slave_name, link) != 0) {
            fprintf(stderr, "fs_emulator: cannot make link %s: %s\n", link, strerror(errno));
            return -1;
        }
        snprintf(b->link, sizeof(b->link), "%s", link);
    }
    b->uart = find_uart0(avr);
    if (b->uart == NULL) {
        fprintf(stderr, "fs_emulator: this MCU has no UART0\n");
        return -1;
    }
    uint32_t ioctl_uart = AVR_IOCTL_UART_GETIRQ('0');
    b->uart_in = avr_io_getirq(avr, ioctl_uart, UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, ioctl_uart, UART_IRQ_OUTPUT), on_tx, b);
    avr_irq_register_notify(avr_io_getirq(avr, ioctl_uart, UART_IRQ_OUT_XON), on_xon, b);
    avr_irq_register_notify(avr_io_getirq(avr, ioctl_uart, UART_IRQ_OUT_XOFF), on_xoff, b);
    /* No "sleep a bit when polled" hack: the firmware sleeps itself, and we want cycle timing. */
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(uint32_t)(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_cycle_timer_register_usec(avr, IDLE_POLL_US, poll_host, b);
    return 0;
}

void pty_bridge_close(pty_bridge_t *b)
{
    if (b->link[0] != '\0') {
        unlink(b->link);
    }
    if (b->slave >= 0) {
        close(b->slave);
    }
    if (b->master >= 0) {
        close(b->master);
    }
}
