/* Host tests of the device logic: commands, clamping, limits, sequence rules, watchdog. */
#include <string.h>

#include "check.h"
#include "rig.h"
#include "tests.h"

static uint8_t set_limits_entry(uint8_t *p, uint8_t ch, uint16_t min, uint16_t neutral,
                                uint16_t max, uint16_t step)
{
    p[0] = ch;
    fs_put_u16(p + 1, min);
    fs_put_u16(p + 3, neutral);
    fs_put_u16(p + 5, max);
    fs_put_u16(p + 7, step);
    return FS_SIZE_SET_LIMITS_ENTRY;
}

static int expect_nack(rig *r, uint8_t cmd, uint8_t error)
{
    rig_reply rep;
    return rig_one_reply(r, &rep) && rep.cmd == FS_REPLY_NACK && rep.len == FS_SIZE_NACK &&
           rep.payload[0] == cmd && rep.payload[1] == error;
}

static int expect_ack(rig *r, uint8_t cmd, uint8_t clamped)
{
    rig_reply rep;
    return rig_one_reply(r, &rep) && rep.cmd == FS_REPLY_ACK && rep.len == FS_SIZE_ACK &&
           rep.payload[0] == cmd && rep.payload[1] == clamped;
}

static int all_current(const rig *r, uint16_t us)
{
    for (uint8_t ch = 0; ch < r->dev.servos.count; ch++) {
        if (r->dev.servos.current_us[ch] != us) {
            return 0;
        }
    }
    return 1;
}

static void test_boot_state(void)
{
    rig r;
    rig_init(&r, 16);
    CHECK(all_current(&r, FS_US_DEFAULT_NEUTRAL));
    CHECK_EQ(r.dev.servos.dirty, 0xFFFF); /* neutral is written at start */
    CHECK_EQ(fs_device_flags(&r.dev), 0);
}

static void test_ping_and_status(void)
{
    rig r;
    rig_init(&r, 16);
    rig_reply rep;
    rig_send(&r, 5, FS_CMD_PING, NULL, 0);
    CHECK(rig_one_reply(&r, &rep));
    CHECK_EQ(rep.cmd, FS_REPLY_VERSION);
    CHECK_EQ(rep.seq, 5);
    CHECK_EQ(rep.len, FS_SIZE_VERSION);
    CHECK_EQ(rep.payload[0], FS_PROTOCOL_VERSION);
    CHECK_EQ(rep.payload[4], 16);
    CHECK_EQ(rep.payload[5], FS_OUTPUT_PCA9685);
    CHECK_EQ(rep.payload[6], FS_MAX_PAYLOAD);
    r.now += 1234;
    rig_send(&r, 6, FS_CMD_STATUS, NULL, 0);
    CHECK(rig_one_reply(&r, &rep));
    CHECK_EQ(rep.cmd, FS_REPLY_STATUS);
    CHECK_EQ(rep.len, FS_SIZE_STATUS);
    CHECK_EQ(rep.payload[0], 2);                  /* frames_ok: the PING and this STATUS */
    CHECK_EQ(fs_get_u16(rep.payload + 44), 1234); /* uptime, low half */
    CHECK_EQ(fs_get_u16(rep.payload + 50), FS_WATCHDOG_DEFAULT_MS);
    CHECK_EQ(r.dev.seq_valid, 0); /* queries do not take a sequence number */
}

static void test_set_all_and_default_clamp(void)
{
    rig r;
    rig_init(&r, 16);
    uint8_t p[32];
    for (uint8_t ch = 0; ch < 16; ch++) {
        fs_put_u16(p + 2 * ch, (uint16_t)(1100 + 50 * ch)); /* 1100..1850 */
    }
    rig_send(&r, 1, FS_CMD_SET_ALL, p, 32);
    CHECK(expect_ack(&r, FS_CMD_SET_ALL, 0));
    int ok = 1;
    for (uint8_t ch = 0; ch < 16; ch++) {
        ok = ok && r.dev.servos.current_us[ch] == 1100 + 50 * ch;
    }
    CHECK(ok);
    CHECK_EQ(fs_device_flags(&r.dev), FS_FLAG_SEQ_VALID | FS_FLAG_WATCHDOG_ARMED);
    /* Channels never configured are held to the default band. */
    fs_put_u16(p, 0);
    fs_put_u16(p + 2, 65535);
    fs_put_u16(p + 4, 999);
    fs_put_u16(p + 6, 2001);
    rig_send(&r, 2, FS_CMD_SET_ALL, p, 32);
    CHECK(expect_ack(&r, FS_CMD_SET_ALL, 4));
    CHECK_EQ(r.dev.servos.current_us[0], FS_US_DEFAULT_MIN);
    CHECK_EQ(r.dev.servos.current_us[1], FS_US_DEFAULT_MAX);
    CHECK_EQ(r.dev.servos.current_us[2], FS_US_DEFAULT_MIN);
    CHECK_EQ(r.dev.servos.current_us[3], FS_US_DEFAULT_MAX);
    CHECK_EQ(r.dev.counters.clamped, 4);
}

static void test_limits(void)
{
    rig r;
    rig_init(&r, 16);
    uint8_t p[FS_MAX_PAYLOAD];
    uint8_t len = set_limits_entry(p, 3, 800, 1200, 2200, 0);
    len = (uint8_t)(len + set_limits_entry(p + len, 15, 1400, 1500, 1600, 0));
    rig_send(&r, 1, FS_CMD_SET_LIMITS, p, len);
    CHECK(expect_ack(&r, FS_CMD_SET_LIMITS, 0));
    CHECK(fs_device_flags(&r.dev) & FS_FLAG_LIMITS_SET);
    uint8_t some[9] = {3, 0, 0, 15, 0, 0, 4, 0, 0};
    fs_put_u16(some + 1, 700);
    fs_put_u16(some + 4, 1700);
    fs_put_u16(some + 7, 700);
    rig_send(&r, 2, FS_CMD_SET_SOME, some, 9);
    CHECK(expect_ack(&r, FS_CMD_SET_SOME, 3));
    CHECK_EQ(r.dev.servos.current_us[3], 800);
    CHECK_EQ(r.dev.servos.current_us[15], 1600);
    CHECK_EQ(r.dev.servos.current_us[4], FS_US_DEFAULT_MIN); /* untouched limits: default */
    fs_put_u16(some + 1, 2300);
    rig_send(&r, 3, FS_CMD_SET_SOME, some, 3);
    CHECK(expect_ack(&r, FS_CMD_SET_SOME, 1));
    CHECK_EQ(r.dev.servos.current_us[3], 2200);
    /* Narrowing limits pulls the current position inside at once. */
    set_limits_entry(p, 3, 900, 1000, 1100, 0);
    rig_send(&r, 4, FS_CMD_SET_LIMITS, p, FS_SIZE_SET_LIMITS_ENTRY);
    CHECK(expect_ack(&r, FS_CMD_SET_LIMITS, 0));
    CHECK_EQ(r.dev.servos.current_us[3], 1100);
    /* NEUTRAL uses each channel's own neutral. */
    rig_send(&r, 5, FS_CMD_NEUTRAL, NULL, 0);
    CHECK(expect_ack(&r, FS_CMD_NEUTRAL, 0));
    CHECK_EQ(r.dev.servos.current_us[3], 1000);
    CHECK_EQ(r.dev.servos.current_us[15], 1500);
    CHECK_EQ(r.dev.servos.current_us[0], FS_US_DEFAULT_NEUTRAL);
}

static void test_bad_values_change_nothing(void)
{
    rig r;
    rig_init(&r, 16);
    uint8_t p[FS_MAX_PAYLOAD];
    fs_servos before = r.dev.servos;
    struct {
        uint16_t min, neutral, max;
    } bad[] = {{499, 1500, 2000}, {1000, 1500, 2501}, {1600, 1500, 2000}, {1000, 2100, 2000},
               {2000, 1500, 1000}};
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        uint8_t len = set_limits_entry(p, 0, 1000, 1500, 2000, 0); /* a good entry first */
        len = (uint8_t)(len + set_limits_entry(p + len, 1, bad[i].min, bad[i].neutral, bad[i].max, 0));
        rig_send(&r, (uint16_t)(10 + i), FS_CMD_SET_LIMITS, p, len);
        CHECK(expect_nack(&r, FS_CMD_SET_LIMITS, FS_ERR_BAD_VALUE));
    }
    set_limits_entry(p, 16, 1000, 1500, 2000, 0);
    rig_send(&r, 20, FS_CMD_SET_LIMITS, p, FS_SIZE_SET_LIMITS_ENTRY);
    CHECK(expect_nack(&r, FS_CMD_SET_LIMITS, FS_ERR_BAD_CHANNEL));
    uint8_t some[6] = {0, 0xD0, 0x07, 16, 0xD0, 0x07}; /* channel 0 fine, channel 16 not */
    rig_send(&r, 21, FS_CMD_SET_SOME, some, 6);
    CHECK(expect_nack(&r, FS_CMD_SET_SOME, FS_ERR_BAD_CHANNEL));
    uint16_t wd_bad[] = {0, FS_WATCHDOG_MIN_MS - 1, FS_WATCHDOG_MAX_MS + 1, 65535};
    for (size_t i = 0; i < 4; i++) {
        uint8_t w[2];
        fs_put_u16(w, wd_bad[i]);
        rig_send(&r, (uint16_t)(30 + i), FS_CMD_SET_WATCHDOG, w, 2);
        CHECK(expect_nack(&r, FS_CMD_SET_WATCHDOG, FS_ERR_BAD_VALUE));
    }
    CHECK(memcmp(&before, &r.dev.servos, sizeof(before)) == 0);
    CHECK_EQ(r.dev.watchdog_ms, FS_WATCHDOG_DEFAULT_MS);
    CHECK_EQ(r.dev.counters.bad_value, 11);
    CHECK_EQ(r.dev.counters.frames_ok, 0);
    CHECK_EQ(fs_device_flags(&r.dev), 0);
}

static void test_wrong_payload_sizes(void)
{
    /* For each command, sizes that must be refused. */
    static const struct {
        uint8_t cmd;
        uint8_t sizes[8];
        uint8_t n;
    } cases[] = {
        {FS_CMD_PING, {1, 2, 144}, 3},
        {FS_CMD_STATUS, {1, 53}, 2},
        {FS_CMD_SET_ALL, {0, 2, 30, 31, 33, 34, 144}, 7},
        {FS_CMD_SET_SOME, {0, 1, 2, 4, 5, 49, 51, 144}, 8},
        {FS_CMD_NEUTRAL, {1, 32}, 2},
        {FS_CMD_SET_LIMITS, {0, 1, 8, 10, 17, 19, 143}, 7},
        {FS_CMD_SET_WATCHDOG, {0, 1, 3, 4}, 4},
    };
    rig r;
    rig_init(&r, 16);
    fs_servos before = r.dev.servos;
    uint8_t p[FS_MAX_PAYLOAD];
    memset(p, 0, sizeof(p));
    int all = 1, count = 0;
    uint16_t seq = 100;
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        for (uint8_t k = 0; k < cases[i].n; k++) {
            rig_send(&r, seq++, cases[i].cmd, p, cases[i].sizes[k]);
            all = all && expect_nack(&r, cases[i].cmd, FS_ERR_BAD_LENGTH);
            count++;
        }
    }
    CHECK(all);
    CHECK_EQ(r.dev.counters.bad_length, count);
    CHECK(memcmp(&before, &r.dev.servos, sizeof(before)) == 0);
    CHECK_EQ(r.dev.counters.frames_ok, 0);
}

static void test_unknown_command(void)
{
    rig r;
    rig_init(&r, 16);
    int all = 1;
    for (int cmd = 0; cmd < 256; cmd++) {
        switch (cmd) {
        case FS_CMD_PING: case FS_CMD_STATUS: case FS_CMD_SET_ALL: case FS_CMD_SET_SOME:
        case FS_CMD_NEUTRAL: case FS_CMD_SET_LIMITS: case FS_CMD_SET_WATCHDOG:
            continue;
        default:
            rig_send(&r, 1, (uint8_t)cmd, NULL, 0);
            all = all && expect_nack(&r, (uint8_t)cmd, FS_ERR_UNKNOWN_COMMAND);
        }
    }
    CHECK(all);
    CHECK_EQ(r.dev.counters.unknown_command, 249);
}

static void test_sequence_rules(void)
{
    rig r;
    rig_init(&r, 16);
    uint8_t p[32];
    rig_all(p, 16, 1200);
    rig_send(&r, 65534, FS_CMD_SET_ALL, p, 32); /* the first after boot: any SEQ */
    CHECK(expect_ack(&r, FS_CMD_SET_ALL, 0));
    rig_all(p, 16, 1300);
    rig_send(&r, 65534, FS_CMD_SET_ALL, p, 32); /* replay */
    CHECK(expect_nack(&r, FS_CMD_SET_ALL, FS_ERR_STALE_SEQUENCE));
    rig_send(&r, 100, FS_CMD_SET_ALL, p, 32); /* 65534 + 102 wraps past 0: newer */
    CHECK(expect_ack(&r, FS_CMD_SET_ALL, 0));
    CHECK(all_current(&r, 1300));
    rig_all(p, 16, 1400);
    rig_send(&r, 65535, FS_CMD_SET_ALL, p, 32); /* older across the wrap */
    CHECK(expect_nack(&r, FS_CMD_SET_ALL, FS_ERR_STALE_SEQUENCE));
    rig_send(&r, (uint16_t)(100 + 0x8000), FS_CMD_SET_ALL, p, 32); /* half a circle: refused */
    CHECK(expect_nack(&r, FS_CMD_SET_ALL, FS_ERR_STALE_SEQUENCE));
    rig_send(&r, (uint16_t)(100 + 0x7FFF), FS_CMD_SET_ALL, p, 32);
    CHECK(expect_ack(&r, FS_CMD_SET_ALL, 0));
    CHECK_EQ(r.dev.counters.stale_sequence, 3);
    /* Every state-changing command is checked; refused ones change nothing. */
    const uint16_t old = (uint16_t)(100 + 0x7FFF - 5);
    uint8_t lim[9];
    set_limits_entry(lim, 0, 1400, 1450, 1500, 0);
    rig_send(&r, old, FS_CMD_SET_LIMITS, lim, 9);
    CHECK(expect_nack(&r, FS_CMD_SET_LIMITS, FS_ERR_STALE_SEQUENCE));
    rig_send(&r, old, FS_CMD_NEUTRAL, NULL, 0);
    CHECK(expect_nack(&r, FS_CMD_NEUTRAL, FS_ERR_STALE_SEQUENCE));
    uint8_t w[2] = {100, 0};
    rig_send(&r, old, FS_CMD_SET_WATCHDOG, w, 2);
    CHECK(expect_nack(&r, FS_CMD_SET_WATCHDOG, FS_ERR_STALE_SEQUENCE));
    CHECK(all_current(&r, 1400));
    CHECK_EQ(r.dev.servos.limits[0].min_us, FS_US_DEFAULT_MIN);
    CHECK_EQ(r.dev.watchdog_ms, FS_WATCHDOG_DEFAULT_MS);
    /* Queries are not checked and do not advance. */
    rig_reply rep;
    rig_send(&r, old, FS_CMD_PING, NULL, 0);
    CHECK(rig_one_reply(&r, &rep) && rep.cmd == FS_REPLY_VERSION && rep.seq == old);
    CHECK_EQ(r.dev.last_seq, (uint16_t)(100 + 0x7FFF));
    CHECK(fs_seq_newer(0, 65535));
    CHECK(!fs_seq_newer(5, 5));
    CHECK(!fs_seq_newer(0x8000, 0));
    CHECK(fs_seq_newer(0x7FFF, 0));
}

static void test_watchdog(void)
{
    rig r;
    rig_init(&r, 16);
    uint8_t p[32];
    rig_all(p, 16, 1800);
    rig_send(&r, 1, FS_CMD_SET_ALL, p, 32);
    rig_replies(&r, NULL, 0);
    rig_advance(&r, FS_WATCHDOG_DEFAULT_MS - 1);
    CHECK(all_current(&r, 1800));
    rig_advance(&r, 1);
    CHECK(all_current(&r, FS_US_DEFAULT_NEUTRAL));
    CHECK_EQ(r.dev.counters.watchdog_trips, 1);
    CHECK_EQ(fs_device_flags(&r.dev) & FS_FLAG_WATCHDOG_ARMED, 0);
    rig_advance(&r, 2000);
    CHECK_EQ(r.dev.counters.watchdog_trips, 1); /* counted once per silence */
    /* Queries and refused frames do not feed the watchdog. */
    uint8_t w[2];
    fs_put_u16(w, 100);
    rig_send(&r, 2, FS_CMD_SET_WATCHDOG, w, 2);
    CHECK(expect_ack(&r, FS_CMD_SET_WATCHDOG, 0));
    rig_send(&r, 3, FS_CMD_SET_ALL, p, 32);
    rig_replies(&r, NULL, 0);
    for (int i = 0; i < 9; i++) {
        rig_advance(&r, 10);
        rig_send(&r, 4, FS_CMD_PING, NULL, 0);
        rig_send(&r, 3, FS_CMD_SET_ALL, p, 32); /* stale */
    }
    rig_advance(&r, 9);
    CHECK(all_current(&r, 1800));
    rig_advance(&r, 1);
    CHECK(all_current(&r, FS_US_DEFAULT_NEUTRAL));
    CHECK_EQ(r.dev.counters.watchdog_trips, 2);
    /* Position commands keep it fed. */
    uint16_t seq = 10;
    for (int i = 0; i < 50; i++) {
        rig_send(&r, seq++, FS_CMD_SET_ALL, p, 32);
        rig_advance(&r, 99);
    }
    CHECK(all_current(&r, 1800));
    CHECK_EQ(r.dev.counters.watchdog_trips, 2);
}

static void test_rate_limit(void)
{
    rig r;
    rig_init(&r, 16);
    uint8_t lim[9];
    set_limits_entry(lim, 2, 1000, 1500, 2000, 10);
    rig_send(&r, 1, FS_CMD_SET_LIMITS, lim, 9);
    uint8_t some[3] = {2, 0, 0};
    fs_put_u16(some + 1, 1600);
    rig_send(&r, 2, FS_CMD_SET_SOME, some, 3);
    rig_replies(&r, NULL, 0);
    uint16_t last = r.dev.servos.current_us[2];
    int bounded = 1;
    for (int i = 0; i < 400; i++) {
        rig_advance(&r, 1);
        uint16_t now = r.dev.servos.current_us[2];
        bounded = bounded && now >= last && now - last <= 10;
        last = now;
        if (i == 199) {
            CHECK_EQ(now, 1600); /* 100 us at 10 us per 20 ms: 200 ms */
        }
    }
    CHECK(bounded);
    CHECK_EQ(r.dev.servos.current_us[2], 1600);
    /* The watchdog's return to neutral is rate limited too (tripped at 500 ms). */
    CHECK(r.dev.servos.current_us[2] == 1600 && r.dev.counters.watchdog_trips == 0);
    rig_advance(&r, 100 + 20);
    CHECK_EQ(r.dev.counters.watchdog_trips, 1);
    CHECK(r.dev.servos.current_us[2] < 1600 && r.dev.servos.current_us[2] > 1500);
}

static void test_twelve_channels(void)
{
    rig r;
    rig_init(&r, 12);
    uint8_t p[32];
    rig_all(p, 16, 1600);
    rig_send(&r, 1, FS_CMD_SET_ALL, p, 32);
    CHECK(expect_nack(&r, FS_CMD_SET_ALL, FS_ERR_BAD_LENGTH));
    rig_send(&r, 2, FS_CMD_SET_ALL, p, 24);
    CHECK(expect_ack(&r, FS_CMD_SET_ALL, 0));
    CHECK(all_current(&r, 1600));
    uint8_t some[3] = {12, 0x40, 0x06};
    rig_send(&r, 3, FS_CMD_SET_SOME, some, 3);
    CHECK(expect_nack(&r, FS_CMD_SET_SOME, FS_ERR_BAD_CHANNEL));
    CHECK_EQ(r.dev.servos.dirty, 0x0FFF);
}

static void test_fuzz_keeps_limits(void)
{
    /* Random bytes mixed with valid frames of every command: positions never leave limits. */
    rig r;
    rig_init(&r, 16);
    uint32_t seed = 4242;
    uint8_t p[FS_MAX_PAYLOAD];
    int inside = 1;
    for (int i = 0; i < 20000; i++) {
        seed = seed * 1664525u + 1013904223u;
        uint32_t x = seed >> 8;
        if (x % 4 == 0) {
            uint8_t len = (uint8_t)(x % (FS_MAX_PAYLOAD + 1));
            for (uint8_t k = 0; k < len; k++) {
                seed = seed * 1664525u + 1013904223u;
                p[k] = (uint8_t)(seed >> 13);
            }
            static const uint8_t cmds[] = {FS_CMD_SET_ALL, FS_CMD_SET_SOME, FS_CMD_SET_LIMITS,
                                           FS_CMD_NEUTRAL, FS_CMD_SET_WATCHDOG, FS_CMD_STATUS};
            uint8_t cmd = cmds[(x >> 4) % 6];
            if (cmd == FS_CMD_SET_ALL) {
                len = 32;
            }
            rig_send(&r, (uint16_t)(x >> 5), cmd, p, len);
        } else {
            uint8_t b = (uint8_t)(x >> 3);
            rig_feed(&r, &b, 1);
        }
        if (x % 50 == 0) {
            rig_advance(&r, 1 + x % 80);
        }
        for (uint8_t ch = 0; ch < 16; ch++) {
            const fs_limits *l = &r.dev.servos.limits[ch];
            uint16_t c = r.dev.servos.current_us[ch];
            inside = inside && c >= l->min_us && c <= l->max_us && fs_limits_valid(l);
        }
        r.out_len = 0;
    }
    CHECK(inside);
    CHECK(r.dev.counters.frames_ok > 0);
    CHECK(r.dev.counters.stale_sequence > 0);
}

void run_device_tests(void)
{
    test_boot_state();
    test_ping_and_status();
    test_set_all_and_default_clamp();
    test_limits();
    test_bad_values_change_nothing();
    test_wrong_payload_sizes();
    test_unknown_command();
    test_sequence_rules();
    test_watchdog();
    test_rate_limit();
    test_twelve_channels();
    test_fuzz_keeps_limits();
}
