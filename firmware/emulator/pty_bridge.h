/*
 * Bridge between the AVR's UART0 and a pseudo-terminal, single-threaded and paced in emulated
 * time: host bytes enter the UART no faster than the UART's own byte time (as on a real wire),
 * and each one is logged ("rx") at the cycle it is complete in the receiver. Bytes the AVR sends
 * are logged ("tx") and written to the pty.
 *
 * Unlike simavr's uart_pty part it makes no fixed /tmp/simavr-uart0 link: an optional link path
 * is given per run, so parallel runs do not collide.
 *
 * Part of the simavr harness (GPL-3, see README.md): a test tool, not shipped.
 */
#ifndef FS_EMU_PTY_BRIDGE_H
#define FS_EMU_PTY_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#include "emu_log.h"
#include "sim_avr.h"

typedef struct {
    avr_t *avr;
    emu_log_t *log;
    int master;
    int slave; /* kept open so the master never sees a hang-up between host sessions */
    char slave_name[64];
    char link[512];
    uint8_t pending[4096]; /* host bytes not yet in the UART */
    size_t head, len;
    int xoff;
    avr_cycle_count_t next_rx;
    struct avr_uart_t *uart;
    avr_irq_t *uart_in;
    unsigned long tx_dropped;
} pty_bridge_t;

/* Open a pty and connect it to UART0; makes `link` (if not NULL) a symlink to it.
 * Returns 0, or -1 with a message on stderr. */
int pty_bridge_init(pty_bridge_t *b, avr_t *avr, const char *link, emu_log_t *log);
void pty_bridge_close(pty_bridge_t *b);

#endif
