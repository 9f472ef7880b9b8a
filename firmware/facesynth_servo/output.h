/*
 * The servo output seam of the sketch: a PCA9685 board (output_pca9685.cpp) or pins driven by
 * Timer1 (output_pins.cpp), chosen by FS_OUTPUT_MODE in config.h. Positions arrive already
 * clamped (servo_state.c); the output only converts microseconds to its own units.
 */
#ifndef FACESYNTH_OUTPUT_H
#define FACESYNTH_OUTPUT_H

#include <stdint.h>

/* Number of channels this output drives. */
uint8_t output_channels(void);
/* Set the output up; false if the hardware does not answer. */
bool output_begin(void);
/* Write the channels whose bit is set in mask; false if the hardware did not take it. */
bool output_write(const uint16_t *us, uint16_t mask);

#endif
