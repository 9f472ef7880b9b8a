/* Per-channel servo state: limits, neutral, clamping, rate limit. */
#include "servo_state.h"

#include <string.h>

static uint16_t clamp_us(const fs_limits *l, uint16_t us)
{
    if (us < l->min_us) {
        return l->min_us;
    }
    if (us > l->max_us) {
        return l->max_us;
    }
    return us;
}

void fs_servos_init(fs_servos *s, uint8_t count, uint32_t now_ms)
{
    memset(s, 0, sizeof(*s));
    s->count = count > FS_MAX_CHANNELS ? FS_MAX_CHANNELS : count;
    for (uint8_t ch = 0; ch < FS_MAX_CHANNELS; ch++) {
        s->limits[ch].min_us = FS_US_DEFAULT_MIN;
        s->limits[ch].neutral_us = FS_US_DEFAULT_NEUTRAL;
        s->limits[ch].max_us = FS_US_DEFAULT_MAX;
        s->limits[ch].max_step_us = 0;
        s->target_us[ch] = FS_US_DEFAULT_NEUTRAL;
        s->current_us[ch] = FS_US_DEFAULT_NEUTRAL;
    }
    s->dirty = (uint16_t)((1UL << s->count) - 1);
    s->last_step_ms = now_ms;
}

int fs_limits_valid(const fs_limits *l)
{
    return l->min_us >= FS_US_ABS_MIN && l->min_us <= l->neutral_us &&
           l->neutral_us <= l->max_us && l->max_us <= FS_US_ABS_MAX;
}

void fs_servos_set_limits(fs_servos *s, uint8_t ch, const fs_limits *l)
{
    if (ch >= s->count) {
        return;
    }
    s->limits[ch] = *l;
    s->target_us[ch] = clamp_us(l, s->target_us[ch]);
    uint16_t now = clamp_us(l, s->current_us[ch]);
    if (now != s->current_us[ch]) {
        /* A position outside the new limits is never kept, whatever the rate limit. */
        s->current_us[ch] = now;
        s->dirty |= (uint16_t)(1U << ch);
    }
}

int fs_servos_set_target(fs_servos *s, uint8_t ch, uint16_t us)
{
    if (ch >= s->count) {
        return 0;
    }
    uint16_t clamped = clamp_us(&s->limits[ch], us);
    s->target_us[ch] = clamped;
    return clamped != us;
}

void fs_servos_all_neutral(fs_servos *s)
{
    for (uint8_t ch = 0; ch < s->count; ch++) {
        s->target_us[ch] = s->limits[ch].neutral_us;
    }
}

void fs_servos_update(fs_servos *s, uint32_t now_ms)
{
    int step_due = (uint32_t)(now_ms - s->last_step_ms) >= FS_STEP_PERIOD_MS;
    if (step_due) {
        s->last_step_ms = now_ms;
    }
    for (uint8_t ch = 0; ch < s->count; ch++) {
        uint16_t cur = s->current_us[ch];
        uint16_t goal = s->target_us[ch];
        uint16_t step = s->limits[ch].max_step_us;
        if (cur == goal) {
            continue;
        }
        if (step == 0) {
            cur = goal;
        } else if (!step_due) {
            continue;
        } else if (goal > cur) {
            cur = (uint16_t)((goal - cur > step) ? cur + step : goal);
        } else {
            cur = (uint16_t)((cur - goal > step) ? cur - step : goal);
        }
        s->current_us[ch] = cur;
        s->dirty |= (uint16_t)(1U << ch);
    }
}
