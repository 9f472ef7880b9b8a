/* The firmware's logic without hardware: frames -> commands -> servo state, replies, watchdog. */
#include "device.h"

#include <string.h>

int fs_seq_newer(uint16_t seq, uint16_t last)
{
    uint16_t diff = (uint16_t)(seq - last);
    return diff != 0 && diff < 0x8000;
}

void fs_device_init(fs_device *d, uint8_t channels, uint8_t output_kind, uint32_t now_ms,
                    fs_send_fn send, void *ctx)
{
    memset(d, 0, sizeof(*d));
    fs_parser_init(&d->parser);
    fs_servos_init(&d->servos, channels, now_ms);
    d->boot_ms = now_ms;
    d->last_motion_ms = now_ms;
    d->watchdog_ms = FS_WATCHDOG_DEFAULT_MS;
    d->output_kind = output_kind;
    d->send = send;
    d->send_ctx = ctx;
}

uint8_t fs_device_flags(const fs_device *d)
{
    uint8_t flags = 0;
    if (d->seq_valid) {
        flags |= FS_FLAG_SEQ_VALID;
    }
    if (d->watchdog_armed) {
        flags |= FS_FLAG_WATCHDOG_ARMED;
    }
    if (d->limits_set) {
        flags |= FS_FLAG_LIMITS_SET;
    }
    if (d->output_fault) {
        flags |= FS_FLAG_OUTPUT_FAULT;
    }
    return flags;
}

static void reply(fs_device *d, uint16_t seq, uint8_t code, const uint8_t *payload, uint8_t len)
{
    uint8_t frame[FS_SIZE_STATUS + FS_FRAME_OVERHEAD];
    size_t size = fs_encode(frame, sizeof(frame), seq, code, payload, len);
    if (size > 0 && d->send != NULL) {
        d->send(frame, size, d->send_ctx);
    }
}

static void nack(fs_device *d, const fs_frame *f, uint8_t error)
{
    uint8_t payload[FS_SIZE_NACK] = {f->cmd, error};
    reply(d, f->seq, FS_REPLY_NACK, payload, sizeof(payload));
}

static void ack(fs_device *d, const fs_frame *f, uint8_t clamped)
{
    uint8_t payload[FS_SIZE_ACK] = {f->cmd, clamped, fs_device_flags(d)};
    reply(d, f->seq, FS_REPLY_ACK, payload, sizeof(payload));
}

static void send_version(fs_device *d, const fs_frame *f)
{
    uint8_t payload[FS_SIZE_VERSION] = {
        FS_PROTOCOL_VERSION, FS_FIRMWARE_MAJOR, FS_FIRMWARE_MINOR, FS_FIRMWARE_PATCH,
        d->servos.count,     d->output_kind,    FS_MAX_PAYLOAD,
    };
    reply(d, f->seq, FS_REPLY_VERSION, payload, sizeof(payload));
}

static void send_status(fs_device *d, const fs_frame *f, uint32_t now_ms)
{
    const fs_parser_counters *pc = &d->parser.counters;
    const fs_device_counters *dc = &d->counters;
    uint32_t words[12] = {
        dc->frames_ok,       pc->crc_errors,    pc->bad_length + dc->bad_length,
        pc->truncated,       dc->unknown_command, dc->bad_value,
        dc->stale_sequence,  pc->dropped_bytes, dc->watchdog_trips,
        dc->clamped,         dc->output_errors, (uint32_t)(now_ms - d->boot_ms),
    };
    uint8_t payload[FS_SIZE_STATUS];
    for (uint8_t i = 0; i < 12; i++) {
        fs_put_u32(payload + 4 * i, words[i]);
    }
    fs_put_u16(payload + 48, d->last_seq);
    fs_put_u16(payload + 50, d->watchdog_ms);
    payload[52] = fs_device_flags(d);
    reply(d, f->seq, FS_REPLY_STATUS, payload, sizeof(payload));
}

/* Payload size check for a command: 1 if len fits. Repeated payloads need 1..count entries. */
static int size_ok(const fs_device *d, uint8_t cmd, uint8_t len)
{
    switch (cmd) {
    case FS_CMD_PING:
    case FS_CMD_STATUS:
    case FS_CMD_NEUTRAL:
        return len == 0;
    case FS_CMD_SET_ALL:
        return len == FS_SIZE_SET_ALL_ENTRY * d->servos.count;
    case FS_CMD_SET_SOME:
        return len > 0 && len % FS_SIZE_SET_SOME_ENTRY == 0 &&
               len / FS_SIZE_SET_SOME_ENTRY <= d->servos.count;
    case FS_CMD_SET_LIMITS:
        return len > 0 && len % FS_SIZE_SET_LIMITS_ENTRY == 0 &&
               len / FS_SIZE_SET_LIMITS_ENTRY <= d->servos.count;
    case FS_CMD_SET_WATCHDOG:
        return len == FS_SIZE_SET_WATCHDOG;
    default:
        return 0;
    }
}

static void read_limits(const uint8_t *p, fs_limits *l)
{
    l->min_us = fs_get_u16(p + 1);
    l->neutral_us = fs_get_u16(p + 3);
    l->max_us = fs_get_u16(p + 5);
    l->max_step_us = fs_get_u16(p + 7);
}

/* Values check (after the size check): 0 if fine, else an FS_ERR_* code. */
static uint8_t values_error(const fs_device *d, const fs_frame *f)
{
    uint8_t n;
    switch (f->cmd) {
    case FS_CMD_SET_SOME:
        for (n = 0; n < f->len; n += FS_SIZE_SET_SOME_ENTRY) {
            if (f->payload[n] >= d->servos.count) {
                return FS_ERR_BAD_CHANNEL;
            }
        }
        return 0;
    case FS_CMD_SET_LIMITS:
        for (n = 0; n < f->len; n += FS_SIZE_SET_LIMITS_ENTRY) {
            fs_limits l;
            if (f->payload[n] >= d->servos.count) {
                return FS_ERR_BAD_CHANNEL;
            }
            read_limits(f->payload + n, &l);
            if (!fs_limits_valid(&l)) {
                return FS_ERR_BAD_VALUE;
            }
        }
        return 0;
    case FS_CMD_SET_WATCHDOG: {
        uint16_t ms = fs_get_u16(f->payload);
        return (ms < FS_WATCHDOG_MIN_MS || ms > FS_WATCHDOG_MAX_MS) ? FS_ERR_BAD_VALUE : 0;
    }
    default:
        return 0;
    }
}

/* Apply a validated state-changing command; returns how many positions were clamped. */
static uint8_t apply(fs_device *d, const fs_frame *f, uint32_t now_ms)
{
    uint8_t clamped = 0;
    uint8_t n;
    switch (f->cmd) {
    case FS_CMD_SET_ALL:
        for (n = 0; n < d->servos.count; n++) {
            clamped += (uint8_t)fs_servos_set_target(&d->servos, n, fs_get_u16(f->payload + 2 * n));
        }
        break;
    case FS_CMD_SET_SOME:
        for (n = 0; n < f->len; n += FS_SIZE_SET_SOME_ENTRY) {
            clamped += (uint8_t)fs_servos_set_target(&d->servos, f->payload[n],
                                                     fs_get_u16(f->payload + n + 1));
        }
        break;
    case FS_CMD_NEUTRAL:
        fs_servos_all_neutral(&d->servos);
        d->watchdog_armed = 0;
        break;
    case FS_CMD_SET_LIMITS:
        for (n = 0; n < f->len; n += FS_SIZE_SET_LIMITS_ENTRY) {
            fs_limits l;
            read_limits(f->payload + n, &l);
            fs_servos_set_limits(&d->servos, f->payload[n], &l);
        }
        d->limits_set = 1;
        break;
    case FS_CMD_SET_WATCHDOG:
        d->watchdog_ms = fs_get_u16(f->payload);
        break;
    default:
        break;
    }
    if (f->cmd == FS_CMD_SET_ALL || f->cmd == FS_CMD_SET_SOME) {
        d->watchdog_armed = 1;
        d->last_motion_ms = now_ms;
    }
    d->counters.clamped += clamped;
    d->last_seq = f->seq;
    d->seq_valid = 1;
    fs_servos_update(&d->servos, now_ms);
    return clamped;
}

static void handle_frame(fs_device *d, const fs_frame *f, uint32_t now_ms)
{
    switch (f->cmd) {
    case FS_CMD_PING:
    case FS_CMD_STATUS:
    case FS_CMD_SET_ALL:
    case FS_CMD_SET_SOME:
    case FS_CMD_NEUTRAL:
    case FS_CMD_SET_LIMITS:
    case FS_CMD_SET_WATCHDOG:
        break;
    default:
        d->counters.unknown_command++;
        nack(d, f, FS_ERR_UNKNOWN_COMMAND);
        return;
    }
    if (!size_ok(d, f->cmd, f->len)) {
        d->counters.bad_length++;
        nack(d, f, FS_ERR_BAD_LENGTH);
        return;
    }
    uint8_t error = values_error(d, f);
    if (error != 0) {
        d->counters.bad_value++;
        nack(d, f, error);
        return;
    }
    if (f->cmd == FS_CMD_PING) {
        d->counters.frames_ok++;
        send_version(d, f);
        return;
    }
    if (f->cmd == FS_CMD_STATUS) {
        d->counters.frames_ok++;
        send_status(d, f, now_ms);
        return;
    }
    if (d->seq_valid && !fs_seq_newer(f->seq, d->last_seq)) {
        d->counters.stale_sequence++;
        nack(d, f, FS_ERR_STALE_SEQUENCE);
        return;
    }
    d->counters.frames_ok++;
    uint8_t clamped = apply(d, f, now_ms);
    ack(d, f, clamped);
}

static void drain(fs_device *d, uint32_t now_ms)
{
    fs_frame frame;
    while (fs_parser_next(&d->parser, &frame)) {
        handle_frame(d, &frame, now_ms);
    }
}

void fs_device_receive(fs_device *d, uint8_t byte, uint32_t now_ms)
{
    fs_parser_put(&d->parser, byte, now_ms); /* always fits: the queue is drained below */
    drain(d, now_ms);
}

void fs_device_tick(fs_device *d, uint32_t now_ms)
{
    fs_parser_tick(&d->parser, now_ms);
    drain(d, now_ms);
    if (d->watchdog_armed && (uint32_t)(now_ms - d->last_motion_ms) >= d->watchdog_ms) {
        d->watchdog_armed = 0;
        d->counters.watchdog_trips++;
        fs_servos_all_neutral(&d->servos);
    }
    fs_servos_update(&d->servos, now_ms);
}
