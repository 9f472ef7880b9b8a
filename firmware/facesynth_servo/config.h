/*
 * Build-time configuration of the facesynth servo firmware (Arduino Uno, ATmega328P, 16 MHz).
 *
 * FS_OUTPUT_MODE selects the servo output:
 *   FS_OUTPUT_PCA9685 (default): 16 servos on a PCA9685 board over I2C (Adafruit servo shield);
 *   FS_OUTPUT_PINS: up to 12 servos on pins D2..D13, pulses from a Timer1 interrupt.
 * Override with -DFS_OUTPUT_MODE=1 (the Makefile builds both).
 */
#ifndef FACESYNTH_CONFIG_H
#define FACESYNTH_CONFIG_H

#include "protocol.h"

#ifndef FS_OUTPUT_MODE
#define FS_OUTPUT_MODE FS_OUTPUT_PCA9685
#endif

#define FS_BAUD 115200UL

/* PCA9685: 7-bit address, internal oscillator, PRE_SCALE for 50 Hz (25 MHz / (4096 * 122)). */
#define FS_PCA9685_ADDRESS 0x40
#ifndef FS_PCA9685_OSC_HZ
#define FS_PCA9685_OSC_HZ 25000000UL /* trim per board if its oscillator is off */
#endif
#define FS_PCA9685_PRESCALE 121
#define FS_I2C_HZ 400000UL
#define FS_I2C_TIMEOUT_US 5000UL
/* Channel n's pulse starts n * FS_PCA9685_STAGGER ticks into the period, so the 16 servos do
 * not all draw their start current at once (15 * 200 + 512 ticks still fits a 4096-tick period). */
#define FS_PCA9685_STAGGER 200

/* Pins mode: channel n drives digital pin FS_PIN_FIRST + n (D2..D13; D0/D1 are the UART). */
#define FS_PIN_FIRST 2
#define FS_PIN_CHANNELS 12

/* After a failed output write, retry no sooner than this. */
#define FS_OUTPUT_RETRY_MS 20

#endif
