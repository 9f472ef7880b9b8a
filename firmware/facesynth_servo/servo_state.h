/*
 * Per-channel servo state: limits, neutral, clamping, optional rate limit.
 *
 * Plain C99, no Arduino dependency. Every position that reaches `current` (what the output
 * drives) has been clamped to the channel's [min, max]; channels that were never configured use
 * the conservative defaults FS_US_DEFAULT_MIN..FS_US_DEFAULT_MAX with neutral
 * FS_US_DEFAULT_NEUTRAL.
 */
#ifndef FACESYNTH_SERVO_STATE_H
#define FACESYNTH_SERVO_STATE_H

#include <stdint.h>

#include "protocol.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    uint16_t min_us;
    uint16_t neutral_us;
    uint16_t max_us;
    uint16_t max_step_us; /* most a channel moves per FS_STEP_PERIOD_MS; 0 = no limit */
} fs_limits;

typedef struct {
    uint8_t count; /* channels driven, <= FS_MAX_CHANNELS */
    fs_limits limits[FS_MAX_CHANNELS];
    uint16_t target_us[FS_MAX_CHANNELS];  /* clamped goal */
    uint16_t current_us[FS_MAX_CHANNELS]; /* what the output drives now */
    uint16_t dirty;                       /* bit n: current_us[n] changed, output not yet written */
    uint32_t last_step_ms;
} fs_servos;

/* All channels at default limits, target = current = neutral, all dirty (so the output writes
 * neutral at start). */
void fs_servos_init(fs_servos *s, uint8_t count, uint32_t now_ms);
/* 1 if limits are usable: FS_US_ABS_MIN <= min <= neutral <= max <= FS_US_ABS_MAX. */
int fs_limits_valid(const fs_limits *l);
/* Replace a channel's limits (caller validated them) and re-clamp its target and position. */
void fs_servos_set_limits(fs_servos *s, uint8_t ch, const fs_limits *l);
/* Clamp us to the channel's limits and make it the target. Returns 1 if it was clamped. */
int fs_servos_set_target(fs_servos *s, uint8_t ch, uint16_t us);
/* Every channel's target to its neutral. */
void fs_servos_all_neutral(fs_servos *s);
/* Move `current` toward `target`: channels without a rate limit at once, rate-limited ones by
 * max_step_us once per FS_STEP_PERIOD_MS. Marks changed channels dirty. */
void fs_servos_update(fs_servos *s, uint32_t now_ms);

#ifdef __cplusplus
}
#endif

#endif
