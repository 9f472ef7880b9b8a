/*
 * facesynth servo protocol: framing, CRC, an incremental frame parser and a frame encoder.
 *
 * Plain C99 with no Arduino dependency: the same file builds for the ATmega328P and for the
 * host (unit tests). The constants below are the protocol; firmware/PROTOCOL.md documents them
 * and services/control/drivers/arduino/protocol.py mirrors them (tests/firmware checks that the
 * three agree).
 *
 * Frame (both directions), multi-byte fields little-endian:
 *
 *   START(0xA5) | LEN u8 | SEQ u16 | CMD u8 | PAYLOAD[LEN] | CRC u16
 *
 * LEN counts the payload only (0..FS_MAX_PAYLOAD). The CRC is CRC-16/CCITT-FALSE
 * (poly 0x1021, init 0xFFFF, no reflection, xorout 0; "123456789" -> 0x29B1) over LEN, SEQ,
 * CMD and PAYLOAD, i.e. every byte after START and before the CRC.
 */
#ifndef FACESYNTH_PROTOCOL_H
#define FACESYNTH_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define FS_PROTOCOL_VERSION 1

#define FS_START 0xA5
#define FS_HEADER_SIZE 5 /* START, LEN, SEQ (2), CMD */
#define FS_CRC_SIZE 2
#define FS_FRAME_OVERHEAD 7 /* header + CRC */
#define FS_MAX_PAYLOAD 144
#define FS_MAX_FRAME (FS_MAX_PAYLOAD + FS_FRAME_OVERHEAD)
#define FS_MAX_CHANNELS 16
/* A frame whose next byte does not arrive within this time is dropped as truncated. */
#define FS_FRAME_TIMEOUT_MS 50

/* Commands, host -> firmware. */
#define FS_CMD_PING 0x01
#define FS_CMD_STATUS 0x02
#define FS_CMD_SET_ALL 0x10
#define FS_CMD_SET_SOME 0x11
#define FS_CMD_NEUTRAL 0x12
#define FS_CMD_SET_LIMITS 0x20
#define FS_CMD_SET_WATCHDOG 0x21

/* Replies, firmware -> host; SEQ echoes the command's SEQ. */
#define FS_REPLY_ACK 0x80
#define FS_REPLY_NACK 0x81
#define FS_REPLY_VERSION 0x82
#define FS_REPLY_STATUS 0x83

/* NACK error codes. */
#define FS_ERR_UNKNOWN_COMMAND 1
#define FS_ERR_BAD_LENGTH 2
#define FS_ERR_BAD_CHANNEL 3
#define FS_ERR_BAD_VALUE 4
#define FS_ERR_STALE_SEQUENCE 5

/* Payload sizes: fixed payloads, and the entry size of repeated ones. */
#define FS_SIZE_SET_ALL_ENTRY 2
#define FS_SIZE_SET_SOME_ENTRY 3
#define FS_SIZE_SET_LIMITS_ENTRY 9
#define FS_SIZE_SET_WATCHDOG 2
#define FS_SIZE_ACK 3
#define FS_SIZE_NACK 2
#define FS_SIZE_VERSION 7
#define FS_SIZE_STATUS 53

/* Flags byte of ACK and STATUS. */
#define FS_FLAG_SEQ_VALID 0x01      /* a state-changing command was applied since boot */
#define FS_FLAG_WATCHDOG_ARMED 0x02 /* positions are live; 0 = held at neutral */
#define FS_FLAG_LIMITS_SET 0x04     /* SET_LIMITS was applied since boot (0 after a reset) */
#define FS_FLAG_OUTPUT_FAULT 0x08   /* the last write to the servo output failed */

/* Output kinds reported by VERSION. */
#define FS_OUTPUT_PCA9685 0
#define FS_OUTPUT_PINS 1

/* Position and limit bounds, microseconds. */
#define FS_US_ABS_MIN 500
#define FS_US_ABS_MAX 2500
#define FS_US_DEFAULT_MIN 1000
#define FS_US_DEFAULT_NEUTRAL 1500
#define FS_US_DEFAULT_MAX 2000
#define FS_WATCHDOG_DEFAULT_MS 500
#define FS_WATCHDOG_MIN_MS 20
#define FS_WATCHDOG_MAX_MS 60000
/* Rate-limited channels (max_step > 0) move at most max_step us per this period. */
#define FS_STEP_PERIOD_MS 20

/* CRC-16/CCITT-FALSE. Start with FS_CRC_INIT. */
#define FS_CRC_INIT 0xFFFF
uint16_t fs_crc16_update(uint16_t crc, uint8_t byte);
uint16_t fs_crc16(const uint8_t *data, size_t len);

/* Little-endian helpers. */
static inline uint16_t fs_get_u16(const uint8_t *p) { return (uint16_t)(p[0] | ((uint16_t)p[1] << 8)); }
static inline void fs_put_u16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
static inline void fs_put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* A complete, CRC-checked frame. `payload` points into the parser and is valid until the next
 * parser call. */
typedef struct {
    uint16_t seq;
    uint8_t cmd;
    uint8_t len;
    const uint8_t *payload;
} fs_frame;

/* Parser counters (framing level). */
typedef struct {
    uint32_t crc_errors;    /* complete frame, CRC mismatch */
    uint32_t bad_length;    /* LEN above FS_MAX_PAYLOAD */
    uint32_t truncated;     /* frame started but the line went idle for FS_FRAME_TIMEOUT_MS */
    uint32_t dropped_bytes; /* bytes discarded while looking for a START */
} fs_parser_counters;

/*
 * Incremental frame parser with resynchronisation: when a candidate frame fails (bad LEN, bad
 * CRC, timeout) its START is dropped and the bytes after it are scanned again, so a frame hidden
 * behind garbage or behind a cut-off frame is still found.
 *
 * Use: fs_parser_put() one received byte, then call fs_parser_next() until it returns 0 (it
 * returns 1 for each complete frame); call fs_parser_tick() regularly (also followed by
 * fs_parser_next()) so that idle partial frames time out.
 */
#define FS_PARSER_QUEUE (FS_MAX_FRAME + 1)
typedef struct {
    uint8_t cand[FS_MAX_FRAME]; /* the candidate frame, from START on */
    uint8_t cand_len;
    uint16_t crc; /* CRC of the candidate's bytes after START so far */
    uint8_t queue[FS_PARSER_QUEUE]; /* bytes to (re)scan, ring buffer */
    uint8_t q_head;
    uint8_t q_len;
    uint32_t last_byte_ms;
    fs_parser_counters counters;
} fs_parser;

void fs_parser_init(fs_parser *p);
/* Queue one received byte. Returns 0 if the queue is full (call fs_parser_next() first). */
int fs_parser_put(fs_parser *p, uint8_t byte, uint32_t now_ms);
/* Scan queued bytes; returns 1 and fills *out when a frame is complete, 0 when all are used. */
int fs_parser_next(fs_parser *p, fs_frame *out);
/* Drop a partial frame whose last byte is older than FS_FRAME_TIMEOUT_MS (counted as truncated). */
void fs_parser_tick(fs_parser *p, uint32_t now_ms);

/* Encode a frame into out (capacity cap). Returns its size, or 0 if it does not fit or
 * len > FS_MAX_PAYLOAD. */
size_t fs_encode(uint8_t *out, size_t cap, uint16_t seq, uint8_t cmd, const uint8_t *payload,
                 uint8_t len);

#ifdef __cplusplus
}
#endif

#endif
