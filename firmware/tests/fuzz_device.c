/*
 * Fuzz harness: the firmware's real device logic (device.c, protocol.c, servo_state.c) driven
 * from stdin, built for the host with AddressSanitizer and UBSan (make fuzz-harness).
 * tests/fuzz/test_fuzz_firmware_parser.py feeds it hypothesis cases; one process serves them all.
 *
 * A case (stdin), little-endian:  u32 size | u8 channels | ops...   where an op is
 *   'b' u16 n | n bytes    the bytes received over the UART, one by one, at the current time
 *   't' u16 ms             time passes, the device ticked every millisecond like the sketch
 * The device is reset (booted at 1000 ms) at the start of each case. After every byte and every
 * tick the harness checks the safety invariants and counts each breach:
 *   - every channel's limits valid (500 <= min <= neutral <= max <= 2500);
 *   - every channel's target and current position within its limits;
 *   - a rate-limited channel (max_step > 0) whose limits did not change moves at most max_step,
 *     at most once per FS_STEP_PERIOD_MS.
 * The answer (stdout): u32 size | u32 breaches | u8 count | per channel u16 min, neutral, max,
 * max_step, target, current | 8 x u32 device counters | 4 x u32 parser counters | u8 flags |
 * u32 n | n bytes of reply frames.  A malformed case exits with status 2.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "device.h"

#define MAX_CASE (1u << 20)
#define MAX_TICK_MS 5000u
#define MAX_REPLIES 65536u

static uint8_t replies[MAX_REPLIES];
static size_t replies_len;

static void capture(const uint8_t *frame, size_t len, void *ctx)
{
    (void)ctx;
    if (replies_len + len <= sizeof(replies)) {
        memcpy(replies + replies_len, frame, len);
        replies_len += len;
    }
}

typedef struct {
    fs_limits limits[FS_MAX_CHANNELS];
    uint16_t current[FS_MAX_CHANNELS];
    uint32_t last_move_ms[FS_MAX_CHANNELS];
    uint32_t breaches;
} watcher;

static void watch_init(watcher *w, const fs_device *d, uint32_t now)
{
    memset(w, 0, sizeof(*w));
    for (uint8_t ch = 0; ch < d->servos.count; ch++) {
        w->limits[ch] = d->servos.limits[ch];
        w->current[ch] = d->servos.current_us[ch];
        w->last_move_ms[ch] = now - FS_STEP_PERIOD_MS;
    }
}

static void watch(watcher *w, const fs_device *d, uint32_t now)
{
    for (uint8_t ch = 0; ch < d->servos.count; ch++) {
        const fs_limits *l = &d->servos.limits[ch];
        uint16_t cur = d->servos.current_us[ch];
        uint16_t goal = d->servos.target_us[ch];
        if (!fs_limits_valid(l) || cur < l->min_us || cur > l->max_us || goal < l->min_us ||
            goal > l->max_us) {
            w->breaches++;
        }
        int same_limits = memcmp(l, &w->limits[ch], sizeof(*l)) == 0;
        if (cur != w->current[ch]) {
            if (same_limits && l->max_step_us > 0) {
                unsigned delta = cur > w->current[ch] ? (unsigned)(cur - w->current[ch])
                                                      : (unsigned)(w->current[ch] - cur);
                if (delta > l->max_step_us || now - w->last_move_ms[ch] < FS_STEP_PERIOD_MS) {
                    w->breaches++;
                }
            }
            w->last_move_ms[ch] = now;
        }
        w->limits[ch] = *l;
        w->current[ch] = cur;
    }
}

static int read_exact(void *buf, size_t n)
{
    return fread(buf, 1, n, stdin) == n;
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static void put(const void *data, size_t n, uint8_t *out, size_t *len)
{
    memcpy(out + *len, data, n);
    *len += n;
}

static void put_u16(uint16_t v, uint8_t *out, size_t *len)
{
    uint8_t b[2];
    fs_put_u16(b, v);
    put(b, 2, out, len);
}

static void put_u32(uint32_t v, uint8_t *out, size_t *len)
{
    uint8_t b[4];
    fs_put_u32(b, v);
    put(b, 4, out, len);
}

static int run_case(const uint8_t *c, size_t size, uint8_t *out, size_t *out_len)
{
    static fs_device dev;
    static watcher w;
    if (size < 1) {
        return 0;
    }
    uint32_t now = 1000;
    replies_len = 0;
    fs_device_init(&dev, c[0], FS_OUTPUT_PCA9685, now, capture, NULL);
    watch_init(&w, &dev, now);
    size_t i = 1;
    while (i < size) {
        uint8_t op = c[i++];
        if (i + 2 > size) {
            return 0;
        }
        uint16_t n = fs_get_u16(c + i);
        i += 2;
        if (op == 'b') {
            if (i + n > size) {
                return 0;
            }
            for (uint16_t k = 0; k < n; k++) {
                fs_device_receive(&dev, c[i + k], now);
                watch(&w, &dev, now);
            }
            i += n;
        } else if (op == 't') {
            if (n > MAX_TICK_MS) {
                return 0;
            }
            for (uint16_t k = 0; k < n; k++) {
                now++;
                fs_device_tick(&dev, now);
                watch(&w, &dev, now);
            }
        } else {
            return 0;
        }
    }
    *out_len = 0;
    put_u32(w.breaches, out, out_len);
    out[(*out_len)++] = dev.servos.count;
    for (uint8_t ch = 0; ch < dev.servos.count; ch++) {
        const fs_limits *l = &dev.servos.limits[ch];
        put_u16(l->min_us, out, out_len);
        put_u16(l->neutral_us, out, out_len);
        put_u16(l->max_us, out, out_len);
        put_u16(l->max_step_us, out, out_len);
        put_u16(dev.servos.target_us[ch], out, out_len);
        put_u16(dev.servos.current_us[ch], out, out_len);
    }
    const fs_device_counters *dc = &dev.counters;
    uint32_t counters[8] = {dc->frames_ok,      dc->unknown_command, dc->bad_length,
                            dc->bad_value,      dc->stale_sequence,  dc->watchdog_trips,
                            dc->clamped,        dc->output_errors};
    for (int k = 0; k < 8; k++) {
        put_u32(counters[k], out, out_len);
    }
    const fs_parser_counters *pc = &dev.parser.counters;
    put_u32(pc->crc_errors, out, out_len);
    put_u32(pc->bad_length, out, out_len);
    put_u32(pc->truncated, out, out_len);
    put_u32(pc->dropped_bytes, out, out_len);
    out[(*out_len)++] = fs_device_flags(&dev);
    put_u32((uint32_t)replies_len, out, out_len);
    put(replies, replies_len, out, out_len);
    return 1;
}

int main(void)
{
    static uint8_t in[MAX_CASE];
    static uint8_t out[MAX_REPLIES + 1024];
    uint8_t head[4];
    while (read_exact(head, 4)) {
        uint32_t size = get_u32(head);
        if (size > MAX_CASE || !read_exact(in, size)) {
            fprintf(stderr, "fuzz_device: bad case size %u\n", size);
            return 2;
        }
        size_t out_len = 0;
        if (!run_case(in, size, out + 4, &out_len)) {
            fprintf(stderr, "fuzz_device: malformed case\n");
            return 2;
        }
        fs_put_u32(out, (uint32_t)out_len);
        if (fwrite(out, 1, out_len + 4, stdout) != out_len + 4 || fflush(stdout) != 0) {
            return 2;
        }
    }
    return 0;
}
