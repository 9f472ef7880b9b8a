/*
 * fs_emulator: runs the facesynth servo firmware on an emulated ATmega328P (simavr) with its
 * UART0 on a pseudo-terminal and an emulated PCA9685 (or pin pulse timing), and logs what the
 * servos would see in emulated time (see emu_log.h for the log format).
 *
 *   fs_emulator --elf build/pca9685/facesynth_servo.elf [--log FILE] [--pty-link PATH]
 *               [--output pca9685|pins] [--no-board] [--max-ms N] [--trace-i2c]
 *               [--pin-tolerance-us X] [--stack-from ADDR] [--board-after-ms N]
 *
 * --board-after-ms connects the PCA9685 only after N ms of emulated time (a board powered late).
 * --stack-from takes the firmware's end of static RAM (the `_end` symbol, `avr-nm`): the RAM from
 * there up is painted before the run and the deepest stack use is logged at the end
 * ("stack <t_us> <bytes used> <bytes never touched>").
 *
 * Prints "pty <slave path>" on stdout once the UART is reachable. Stops on SIGINT / SIGTERM,
 * after --max-ms of emulated time, or when the AVR stops; exit status 0, or 2 if it crashed.
 *
 * Links libsimavr (GPL-3): this program is a separate test tool, see README.md.
 */
#define _GNU_SOURCE
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "emu_log.h"
#include "pca9685.h"
#include "pin_pulses.h"
#include "pty_bridge.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_cycle_timers.h"
#include "sim_time.h"

#define MCU "atmega328p"
#define F_CPU 16000000UL

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

double emu_us(const avr_t *avr, avr_cycle_count_t cycle)
{
    return (double)cycle * 1e6 / (double)avr->frequency;
}

void emu_log(emu_log_t *log, avr_cycle_count_t cycle, const char *kind, const char *fmt, ...)
{
    va_list ap;
    fprintf(log->out, "%s %.3f ", kind, emu_us(log->avr, cycle));
    va_start(ap, fmt);
    vfprintf(log->out, fmt, ap);
    va_end(ap);
    fputc('\n', log->out);
}

typedef struct {
    const char *elf;
    const char *log;
    const char *link;
    const char *output;
    int no_board;
    int trace_i2c;
    double max_ms;
    double pin_tolerance_us;
    unsigned long stack_from;
    double board_after_ms;
} options_t;

#define STACK_PAINT 0xC3

static void usage(void)
{
    fprintf(stderr,
            "usage: fs_emulator --elf FILE [--log FILE] [--pty-link PATH] [--output pca9685|pins]\n"
            "                   [--no-board] [--max-ms N] [--trace-i2c] [--pin-tolerance-us X]\n"
            "                   [--stack-from ADDR] [--board-after-ms N]\n");
}

static int parse(int argc, char **argv, options_t *o)
{
    memset(o, 0, sizeof(*o));
    o->output = "pca9685";
    o->pin_tolerance_us = 8.0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *next = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--no-board") == 0) {
            o->no_board = 1;
        } else if (strcmp(a, "--trace-i2c") == 0) {
            o->trace_i2c = 1;
        } else if (next == NULL) {
            usage();
            return -1;
        } else if (strcmp(a, "--elf") == 0) {
            o->elf = argv[++i];
        } else if (strcmp(a, "--log") == 0) {
            o->log = argv[++i];
        } else if (strcmp(a, "--pty-link") == 0) {
            o->link = argv[++i];
        } else if (strcmp(a, "--output") == 0) {
            o->output = argv[++i];
        } else if (strcmp(a, "--max-ms") == 0) {
            o->max_ms = atof(argv[++i]);
        } else if (strcmp(a, "--board-after-ms") == 0) {
            o->board_after_ms = atof(argv[++i]);
        } else if (strcmp(a, "--stack-from") == 0) {
            o->stack_from = strtoul(argv[++i], NULL, 0) & 0xFFFF; /* avr-nm shows 0x800000 + addr */
        } else if (strcmp(a, "--pin-tolerance-us") == 0) {
            o->pin_tolerance_us = atof(argv[++i]);
        } else {
            usage();
            return -1;
        }
    }
    if (o->elf == NULL || (strcmp(o->output, "pca9685") != 0 && strcmp(o->output, "pins") != 0)) {
        usage();
        return -1;
    }
    return 0;
}

static avr_cycle_count_t attach_board(avr_t *avr, avr_cycle_count_t when, void *param)
{
    pca9685_attach((pca9685_t *)param, avr);
    (void)when;
    return 0;
}

int main(int argc, char **argv)
{
    options_t opt;
    if (parse(argc, argv, &opt) != 0) {
        return 1;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof(fw));
    if (elf_read_firmware(opt.elf, &fw) != 0) {
        fprintf(stderr, "fs_emulator: cannot read firmware %s\n", opt.elf);
        return 1;
    }
    avr_t *avr = avr_make_mcu_by_name(MCU);
    if (avr == NULL || avr_init(avr) != 0) {
        fprintf(stderr, "fs_emulator: simavr has no %s\n", MCU);
        return 1;
    }
    fw.frequency = F_CPU;
    avr_load_firmware(avr, &fw);
    avr->frequency = F_CPU;
    avr->log = LOG_WARNING;
    if (opt.stack_from > avr->ramend) {
        fprintf(stderr, "fs_emulator: --stack-from 0x%lx is beyond RAM\n", opt.stack_from);
        return 1;
    }
    if (opt.stack_from != 0) {
        memset(avr->data + opt.stack_from, STACK_PAINT, avr->ramend + 1 - opt.stack_from);
    }

    FILE *out = stdout;
    if (opt.log != NULL && (out = fopen(opt.log, "w")) == NULL) {
        perror(opt.log);
        return 1;
    }
    setvbuf(out, NULL, _IOLBF, 0);
    emu_log_t log = {avr, out};

    static pty_bridge_t bridge;
    if (pty_bridge_init(&bridge, avr, opt.link, &log) != 0) {
        pty_bridge_close(&bridge);
        return 1;
    }
    static pca9685_t board;
    static pin_pulses_t pins;
    if (strcmp(opt.output, "pins") == 0) {
        pin_pulses_attach(&pins, avr, &log, opt.pin_tolerance_us);
    } else if (!opt.no_board) {
        pca9685_init(&board, avr, 0x40, &log, opt.trace_i2c);
        if (opt.board_after_ms > 0) {
            avr_cycle_timer_register_usec(avr, (uint32_t)(opt.board_after_ms * 1000), attach_board,
                                          &board);
        } else {
            pca9685_attach(&board, avr);
        }
    }

    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    printf("pty %s\n", bridge.slave_name);
    fflush(stdout);

    avr_cycle_count_t limit = opt.max_ms > 0 ? avr_usec_to_cycles(avr, (uint32_t)(opt.max_ms * 1000)) : 0;
    int state = cpu_Running;
    while (!stop_requested && state != cpu_Done && state != cpu_Crashed) {
        state = avr_run(avr);
        if (limit != 0 && avr->cycle >= limit) {
            break;
        }
    }
    if (opt.stack_from != 0) {
        unsigned long low = opt.stack_from;
        while (low <= avr->ramend && avr->data[low] == STACK_PAINT) {
            low++;
        }
        emu_log(&log, avr->cycle, "stack", "%lu %lu", (unsigned long)avr->ramend + 1 - low,
                low - opt.stack_from);
    }
    emu_log(&log, avr->cycle, "end", "%s", state == cpu_Crashed ? "crashed" : "stopped");
    if (bridge.tx_dropped > 0) {
        fprintf(stderr, "fs_emulator: %lu bytes to the host were dropped (nobody reading)\n",
                bridge.tx_dropped);
    }
    pty_bridge_close(&bridge);
    if (out != stdout) {
        fclose(out);
    }
    return state == cpu_Crashed ? 2 : 0;
}
