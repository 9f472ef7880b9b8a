/*
 * facesynth servo firmware for an Arduino Uno (ATmega328P, 16 MHz).
 *
 * Receives framed, CRC-checked commands on the USB serial port at 115200 baud (firmware/PROTOCOL.md)
 * and drives 16 servos on a PCA9685 board (or 12 on pins, see config.h). All protocol and safety
 * logic is in plain C (protocol.c, servo_state.c, device.c, tested on the host); this file only
 * connects it to the UART, millis() and the output, and sleeps when idle.
 */
#include <Arduino.h>
#include <avr/sleep.h>
#include <avr/wdt.h>

#include "config.h"
#include "device.h"
#include "output.h"

static fs_device dev;
static uint32_t retry_after_ms;

static void send_frame(const uint8_t *frame, size_t len, void *ctx)
{
    (void)ctx;
    Serial.write(frame, len);
}

static void output_failed(uint32_t now_ms)
{
    dev.output_fault = 1;
    dev.counters.output_errors++;
    retry_after_ms = now_ms + FS_OUTPUT_RETRY_MS;
}

/* Write the channels that changed. After a failure, wait FS_OUTPUT_RETRY_MS, set the output up
 * again (a board that was absent or lost power is asleep at its power-on defaults) and rewrite
 * every channel. */
static void flush_outputs(uint32_t now_ms)
{
    uint16_t mask = dev.servos.dirty;
    if (dev.output_fault) {
        if ((int32_t)(now_ms - retry_after_ms) < 0) {
            return;
        }
        if (!output_begin()) {
            output_failed(now_ms);
            return;
        }
        mask = (uint16_t)((1UL << dev.servos.count) - 1);
    }
    if (mask == 0) {
        return;
    }
    dev.servos.dirty = 0;
    if (output_write(dev.servos.current_us, mask)) {
        dev.output_fault = 0;
        return;
    }
    dev.servos.dirty |= mask;
    output_failed(now_ms);
}

/* Sleep until the next interrupt (UART byte, millis tick) unless a byte is already waiting. */
static void idle(void)
{
    set_sleep_mode(SLEEP_MODE_IDLE);
    cli();
    if (Serial.available() == 0) {
        sleep_enable();
        sei(); /* the instruction after sei runs before any interrupt: no lost wake-up */
        sleep_cpu();
        sleep_disable();
    }
    sei();
}

void setup()
{
    MCUSR = 0;
    wdt_disable();
    Serial.begin(FS_BAUD);
    fs_device_init(&dev, output_channels(), FS_OUTPUT_MODE, millis(), send_frame, NULL);
    if (!output_begin()) {
        output_failed(millis());
    }
    flush_outputs(millis()); /* every channel to neutral */
    wdt_enable(WDTO_250MS);  /* a hung loop resets the board (and so returns to neutral) */
}

void loop()
{
    wdt_reset();
    int byte;
    while ((byte = Serial.read()) >= 0) {
        uint32_t now = millis();
        fs_device_receive(&dev, (uint8_t)byte, now);
        flush_outputs(now);
    }
    uint32_t now = millis();
    fs_device_tick(&dev, now);
    flush_outputs(now);
    idle();
}
