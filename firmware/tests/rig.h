/* Test rig for the host tests: an fs_device fed byte by byte, its replies captured and decoded. */
#ifndef FS_RIG_H
#define FS_RIG_H

#include <stddef.h>
#include <stdint.h>

#include "device.h"

typedef struct {
    uint16_t seq;
    uint8_t cmd;
    uint8_t len;
    uint8_t payload[FS_MAX_PAYLOAD];
} rig_reply;

typedef struct {
    fs_device dev;
    uint8_t out[8192]; /* reply bytes not yet decoded */
    size_t out_len;
    uint32_t now;
} rig;

void rig_init(rig *r, uint8_t channels);
/* Feed bytes at r->now. */
void rig_feed(rig *r, const uint8_t *data, size_t len);
/* Encode a frame into out (FS_MAX_FRAME bytes); returns its size. */
size_t rig_frame(uint8_t *out, uint16_t seq, uint8_t cmd, const uint8_t *payload, uint8_t len);
/* Encode and feed one frame. */
void rig_send(rig *r, uint16_t seq, uint8_t cmd, const uint8_t *payload, uint8_t len);
/* Decode the captured replies into out (at most max); returns how many; clears the capture. */
int rig_replies(rig *r, rig_reply *out, int max);
/* Exactly one reply expected: returns 1 and fills *out, else 0. */
int rig_one_reply(rig *r, rig_reply *out);
/* Advance time by ms, ticking every millisecond like the sketch. */
void rig_advance(rig *r, uint32_t ms);
/* SET_ALL payload with every channel at us. */
uint8_t rig_all(uint8_t *payload, uint8_t channels, uint16_t us);

#endif
