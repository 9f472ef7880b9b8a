/* Test rig for the host tests (see rig.h). */
#include "rig.h"

#include <string.h>

static void capture(const uint8_t *frame, size_t len, void *ctx)
{
    rig *r = (rig *)ctx;
    if (r->out_len + len <= sizeof(r->out)) {
        memcpy(r->out + r->out_len, frame, len);
        r->out_len += len;
    }
}

void rig_init(rig *r, uint8_t channels)
{
    memset(r, 0, sizeof(*r));
    r->now = 1000;
    fs_device_init(&r->dev, channels, FS_OUTPUT_PCA9685, r->now, capture, r);
}

void rig_feed(rig *r, const uint8_t *data, size_t len)
{
    for (size_t i = 0; i < len; i++) {
        fs_device_receive(&r->dev, data[i], r->now);
    }
}

size_t rig_frame(uint8_t *out, uint16_t seq, uint8_t cmd, const uint8_t *payload, uint8_t len)
{
    return fs_encode(out, FS_MAX_FRAME, seq, cmd, payload, len);
}

void rig_send(rig *r, uint16_t seq, uint8_t cmd, const uint8_t *payload, uint8_t len)
{
    uint8_t frame[FS_MAX_FRAME];
    size_t size = rig_frame(frame, seq, cmd, payload, len);
    rig_feed(r, frame, size);
}

int rig_replies(rig *r, rig_reply *out, int max)
{
    fs_parser p;
    fs_frame f;
    int n = 0;
    fs_parser_init(&p);
    for (size_t i = 0; i < r->out_len; i++) {
        fs_parser_put(&p, r->out[i], 0);
        while (fs_parser_next(&p, &f)) {
            if (n < max) {
                out[n].seq = f.seq;
                out[n].cmd = f.cmd;
                out[n].len = f.len;
                memcpy(out[n].payload, f.payload, f.len);
            }
            n++;
        }
    }
    r->out_len = 0;
    return n;
}

int rig_one_reply(rig *r, rig_reply *out)
{
    rig_reply replies[4];
    int n = rig_replies(r, replies, 4);
    if (n != 1) {
        return 0;
    }
    *out = replies[0];
    return 1;
}

void rig_advance(rig *r, uint32_t ms)
{
    for (uint32_t i = 0; i < ms; i++) {
        r->now++;
        fs_device_tick(&r->dev, r->now);
    }
}

uint8_t rig_all(uint8_t *payload, uint8_t channels, uint16_t us)
{
    for (uint8_t ch = 0; ch < channels; ch++) {
        fs_put_u16(payload + 2 * ch, us);
    }
    return (uint8_t)(2 * channels);
}
