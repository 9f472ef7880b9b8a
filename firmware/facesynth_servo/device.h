/*
 * The firmware's logic without hardware: bytes in -> frames -> commands -> servo state and
 * framed replies out; plus the command watchdog.
 *
 * Plain C99, no Arduino dependency: the sketch feeds it UART bytes and millis() and writes the
 * channels marked dirty in `servos` to the output; the host tests drive it the same way.
 *
 * Rules:
 * - a frame is applied only if it is well formed (CRC, LEN, payload size for its command, every
 *   channel < channel count, valid limits / watchdog values); anything else changes nothing and
 *   is counted once (parser counters, unknown_command, bad_length, bad_value, stale_sequence);
 * - state-changing commands (SET_ALL, SET_SOME, NEUTRAL, SET_LIMITS, SET_WATCHDOG) must carry a
 *   SEQ newer than the last applied one, in serial-number arithmetic:
 *   0 < (seq - last) mod 65536 < 32768; the first one after boot is always newer. PING and STATUS
 *   are queries: not checked, do not advance SEQ;
 * - SET_ALL / SET_SOME arm the watchdog; when no SET_ALL / SET_SOME is applied for watchdog_ms,
 *   every target goes to neutral once (counted as a watchdog trip) until the next one.
 */
#ifndef FACESYNTH_DEVICE_H
#define FACESYNTH_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "protocol.h"
#include "servo_state.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    uint32_t frames_ok;
    uint32_t unknown_command;
    uint32_t bad_length; /* payload size wrong for the command */
    uint32_t bad_value;  /* bad channel, bad limits, bad watchdog value */
    uint32_t stale_sequence;
    uint32_t watchdog_trips;
    uint32_t clamped;       /* positions clamped to a channel's limits */
    uint32_t output_errors; /* failed writes to the servo output (counted by the sketch) */
} fs_device_counters;

/* Called with each encoded reply frame. */
typedef void (*fs_send_fn)(const uint8_t *frame, size_t len, void *ctx);

typedef struct {
    fs_parser parser;
    fs_servos servos;
    fs_device_counters counters;
    uint32_t boot_ms;
    uint32_t last_motion_ms;
    uint16_t watchdog_ms;
    uint16_t last_seq;
    uint8_t seq_valid;
    uint8_t watchdog_armed;
    uint8_t limits_set;
    uint8_t output_fault;
    uint8_t output_kind; /* FS_OUTPUT_* */
    fs_send_fn send;
    void *send_ctx;
} fs_device;

/* Firmware version reported by PING. */
#define FS_FIRMWARE_MAJOR 0
#define FS_FIRMWARE_MINOR 1
#define FS_FIRMWARE_PATCH 0

void fs_device_init(fs_device *d, uint8_t channels, uint8_t output_kind, uint32_t now_ms,
                    fs_send_fn send, void *ctx);
/* One received byte: parses, applies complete frames, sends replies. */
void fs_device_receive(fs_device *d, uint8_t byte, uint32_t now_ms);
/* Regular housekeeping (call every loop): frame timeout, watchdog, rate-limited motion. */
void fs_device_tick(fs_device *d, uint32_t now_ms);
/* The ACK / STATUS flags byte (FS_FLAG_*). */
uint8_t fs_device_flags(const fs_device *d);
/* Serial-number comparison: 1 if seq is newer than last. */
int fs_seq_newer(uint16_t seq, uint16_t last);

#ifdef __cplusplus
}
#endif

#endif
