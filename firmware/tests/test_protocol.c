/* Host tests of framing: CRC, encoder, parser, resynchronisation after malformed input. */
#include <string.h>

#include "check.h"
#include "protocol.h"
#include "tests.h"

typedef struct {
    fs_parser p;
    fs_frame frames[64];
    uint8_t payloads[64][FS_MAX_PAYLOAD];
    int n;
    int put_failures; /* must stay 0: the queue is drained after every byte */
} collector;

static void collect(collector *c)
{
    fs_frame f;
    while (fs_parser_next(&c->p, &f)) {
        if (c->n < 64) {
            memcpy(c->payloads[c->n], f.payload, f.len);
            c->frames[c->n] = f;
            c->frames[c->n].payload = c->payloads[c->n];
        }
        c->n++;
    }
}

static void feed(collector *c, const uint8_t *data, size_t len, uint32_t now)
{
    for (size_t i = 0; i < len; i++) {
        c->put_failures += !fs_parser_put(&c->p, data[i], now);
        collect(c);
    }
}

static void reset(collector *c)
{
    memset(c, 0, sizeof(*c));
    fs_parser_init(&c->p);
}

static uint32_t lcg(uint32_t *state)
{
    *state = *state * 1664525u + 1013904223u;
    return *state >> 8;
}

/* The textbook bit-at-a-time CRC-16/CCITT update, as the reference. */
static uint16_t crc_bitwise(uint16_t crc, uint8_t byte)
{
    crc ^= (uint16_t)(byte << 8);
    for (int i = 0; i < 8; i++) {
        crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
    }
    return crc;
}

static void test_crc(void)
{
    CHECK_EQ(fs_crc16((const uint8_t *)"123456789", 9), 0x29B1); /* CRC-16/CCITT-FALSE check */
    CHECK_EQ(fs_crc16(NULL, 0), 0xFFFF);
    int same = 1;
    for (uint32_t crc = 0; crc <= 0xFFFF; crc++) {
        for (uint32_t byte = 0; byte <= 0xFF; byte++) {
            same = same && fs_crc16_update((uint16_t)crc, (uint8_t)byte) ==
                               crc_bitwise((uint16_t)crc, (uint8_t)byte);
        }
    }
    CHECK(same); /* the fast update equals the bit loop for every state and byte */
}

static void test_encode_layout(void)
{
    uint8_t out[FS_MAX_FRAME];
    uint8_t payload[2] = {0xDC, 0x05};
    size_t n = fs_encode(out, sizeof(out), 0x1234, FS_CMD_SET_WATCHDOG, payload, 2);
    CHECK_EQ(n, 9);
    CHECK_EQ(out[0], FS_START);
    CHECK_EQ(out[1], 2);
    CHECK_EQ(out[2], 0x34);
    CHECK_EQ(out[3], 0x12);
    CHECK_EQ(out[4], FS_CMD_SET_WATCHDOG);
    CHECK_EQ(out[5], 0xDC);
    CHECK_EQ(out[6], 0x05);
    uint16_t crc = fs_crc16(out + 1, 6);
    CHECK_EQ(out[7], crc & 0xFF);
    CHECK_EQ(out[8], crc >> 8);
    uint8_t big[FS_MAX_PAYLOAD + 1] = {0};
    CHECK_EQ(fs_encode(out, sizeof(out), 1, 1, big, FS_MAX_PAYLOAD + 1), 0);
    CHECK_EQ(fs_encode(out, 8, 1, 1, payload, 2), 0);
    CHECK_EQ(fs_encode(out, sizeof(out), 1, 1, big, FS_MAX_PAYLOAD), FS_MAX_FRAME);
}

static void test_roundtrip_every_length(void)
{
    collector c;
    reset(&c);
    uint8_t frame[FS_MAX_FRAME];
    uint8_t payload[FS_MAX_PAYLOAD];
    int ok = 1;
    for (int len = 0; len <= FS_MAX_PAYLOAD; len++) {
        for (int i = 0; i < len; i++) {
            payload[i] = (uint8_t)(i * 7 + len); /* includes 0xA5 bytes inside payloads */
        }
        size_t n = fs_encode(frame, sizeof(frame), (uint16_t)(len * 300), 0x42, payload, (uint8_t)len);
        c.n = 0;
        feed(&c, frame, n, 0);
        ok = ok && c.n == 1 && c.frames[0].len == len && c.frames[0].cmd == 0x42 &&
             c.frames[0].seq == (uint16_t)(len * 300) && memcmp(c.payloads[0], payload, len) == 0;
    }
    CHECK(ok);
    CHECK_EQ(c.put_failures, 0);
    CHECK_EQ(c.p.counters.crc_errors + c.p.counters.bad_length + c.p.counters.dropped_bytes, 0);
}

static void test_garbage_between_frames(void)
{
    collector c;
    reset(&c);
    uint8_t frame[FS_MAX_FRAME];
    uint8_t garbage[64];
    uint32_t seed = 12345;
    for (int k = 0; k < 40; k++) {
        for (size_t i = 0; i < sizeof(garbage); i++) {
            uint32_t r = lcg(&seed);
            garbage[i] = (r % 5 == 0) ? FS_START : (uint8_t)r; /* plenty of false starts */
        }
        feed(&c, garbage, 1 + (size_t)(lcg(&seed) % sizeof(garbage)), 0);
        uint8_t payload[3] = {(uint8_t)k, 0xA5, 0x00};
        size_t n = fs_encode(frame, sizeof(frame), (uint16_t)k, FS_CMD_SET_SOME, payload, 3);
        feed(&c, frame, n, 0);
    }
    /* A false start in the last garbage may hold the last frames: let the line go idle (each
     * tick times out one stale candidate, as the firmware's loop does). */
    for (int i = 0; i < 100 && c.p.cand_len > 0; i++) {
        fs_parser_tick(&c.p, FS_FRAME_TIMEOUT_MS);
        collect(&c);
    }
    CHECK_EQ(c.n, 40);
    int in_order = 1;
    for (int k = 0; k < 40 && k < c.n; k++) {
        in_order = in_order && c.frames[k].seq == k && c.payloads[k][0] == k;
    }
    CHECK(in_order);
    CHECK_EQ(c.put_failures, 0);
    CHECK(c.p.counters.dropped_bytes > 0);
    CHECK(c.p.counters.crc_errors + c.p.counters.bad_length > 0);
}

static void test_truncated_then_idle(void)
{
    collector c;
    reset(&c);
    uint8_t frame[FS_MAX_FRAME];
    uint8_t payload[32] = {0};
    size_t n = fs_encode(frame, sizeof(frame), 7, FS_CMD_SET_ALL, payload, 32);
    feed(&c, frame, 10, 100);
    fs_parser_tick(&c.p, 100 + FS_FRAME_TIMEOUT_MS - 1);
    collect(&c);
    CHECK_EQ(c.p.counters.truncated, 0);
    fs_parser_tick(&c.p, 100 + FS_FRAME_TIMEOUT_MS);
    collect(&c);
    CHECK_EQ(c.p.counters.truncated, 1);
    CHECK_EQ(c.n, 0);
    feed(&c, frame, n, 200);
    CHECK_EQ(c.n, 1);
    CHECK_EQ(c.p.counters.crc_errors, 0);
}

static void test_truncated_then_frame(void)
{
    collector c;
    reset(&c);
    uint8_t frame[FS_MAX_FRAME];
    uint8_t payload[32] = {0};
    size_t n = fs_encode(frame, sizeof(frame), 7, FS_CMD_SET_ALL, payload, 32);
    feed(&c, frame, 20, 0);       /* cut off after 20 bytes ... */
    feed(&c, frame, n, 0);        /* ... and the next frame completes its length */
    feed(&c, frame, n, 0);
    fs_parser_tick(&c.p, 1000);
    collect(&c);
    CHECK_EQ(c.n, 2);             /* both whole frames found */
    CHECK_EQ(c.p.counters.crc_errors, 1);
}

static void test_every_bit_flip(void)
{
    uint8_t frame[FS_MAX_FRAME];
    uint8_t payload[32];
    for (int i = 0; i < 32; i++) {
        payload[i] = (uint8_t)(0x10 + i);
    }
    size_t n = fs_encode(frame, sizeof(frame), 0x0102, FS_CMD_SET_ALL, payload, 32);
    int none_accepted = 1, recovered = 1;
    for (size_t byte = 0; byte < n; byte++) {
        for (int bit = 0; bit < 8; bit++) {
            collector c;
            reset(&c);
            uint8_t bad[FS_MAX_FRAME];
            memcpy(bad, frame, n);
            bad[byte] ^= (uint8_t)(1 << bit);
            feed(&c, bad, n, 0);
            fs_parser_tick(&c.p, 1000);
            collect(&c);
            none_accepted = none_accepted && c.n == 0;
            feed(&c, frame, n, 2000);
            fs_parser_tick(&c.p, 5000);
            collect(&c);
            recovered = recovered && c.n == 1 && c.frames[0].seq == 0x0102;
        }
    }
    CHECK(none_accepted);
    CHECK(recovered);
}

static void test_oversized_length(void)
{
    collector c;
    reset(&c);
    uint8_t bogus[] = {FS_START, FS_MAX_PAYLOAD + 1, 0, 0, 0x10, 1, 2, 3};
    feed(&c, bogus, sizeof(bogus), 0);
    CHECK_EQ(c.p.counters.bad_length, 1);
    uint8_t bogus2[] = {FS_START, 0xFF};
    feed(&c, bogus2, sizeof(bogus2), 0);
    CHECK_EQ(c.p.counters.bad_length, 2);
    uint8_t frame[FS_MAX_FRAME];
    size_t n = fs_encode(frame, sizeof(frame), 9, FS_CMD_PING, NULL, 0);
    feed(&c, frame, n, 0);
    CHECK_EQ(c.n, 1);
}

static void test_start_byte_runs(void)
{
    collector c;
    reset(&c);
    uint8_t starts[200];
    memset(starts, FS_START, sizeof(starts)); /* LEN 0xA5 > max: each is a bad length */
    feed(&c, starts, sizeof(starts), 0);
    uint8_t frame[FS_MAX_FRAME];
    size_t n = fs_encode(frame, sizeof(frame), 3, FS_CMD_STATUS, NULL, 0);
    feed(&c, frame, n, 0);
    CHECK_EQ(c.n, 1);
    CHECK_EQ(c.p.counters.bad_length, sizeof(starts));
}

static void test_queue_bound(void)
{
    fs_parser p;
    fs_parser_init(&p);
    int accepted = 0;
    for (int i = 0; i < 400; i++) {
        accepted += fs_parser_put(&p, 0x00, 0); /* never drained */
    }
    CHECK_EQ(accepted, FS_PARSER_QUEUE);
    fs_frame f;
    CHECK_EQ(fs_parser_next(&p, &f), 0);
    CHECK_EQ(p.counters.dropped_bytes, FS_PARSER_QUEUE);
}

static void test_random_streams(void)
{
    /* Random bytes, START-heavy, with idle gaps: no crash (ASan/UBSan), the queue never
     * overflows when drained after every byte, and every error path is exercised. */
    uint32_t seed = 777;
    collector c;
    reset(&c);
    uint32_t now = 0;
    int all_put = 1;
    for (int i = 0; i < 200000; i++) {
        uint32_t r = lcg(&seed);
        uint8_t b = (r % 7 == 0) ? FS_START : (uint8_t)(r >> 3);
        if (r % 1000 == 0) {
            now += FS_FRAME_TIMEOUT_MS;
            fs_parser_tick(&c.p, now);
            collect(&c);
        }
        all_put = all_put && fs_parser_put(&c.p, b, now);
        collect(&c);
    }
    CHECK(all_put);
    CHECK(c.p.counters.crc_errors > 0);
    CHECK(c.p.counters.bad_length > 0);
    CHECK(c.p.counters.truncated > 0);
}

void run_protocol_tests(void)
{
    test_crc();
    test_encode_layout();
    test_roundtrip_every_length();
    test_garbage_between_frames();
    test_truncated_then_idle();
    test_truncated_then_frame();
    test_every_bit_flip();
    test_oversized_length();
    test_start_byte_runs();
    test_queue_bound();
    test_random_streams();
}
