/*
 * Servo output on pins D2..D13 (12 channels), pulses timed by a Timer1 compare interrupt
 * (Debian ships no Arduino Servo library; this does the same job without it).
 *
 * Timer1 free-runs at 2 MHz (prescaler 8, 0.5 us per tick). The channels are pulsed one after
 * the other: each compare match ends the previous channel's pulse and starts the next one, and
 * the next match is set relative to this one (OCR1A += width), so interrupt latency does not add
 * up. After the last channel the sequence waits for the 20 ms frame to end (longer if 12 long
 * pulses do not fit in 20 ms, as with the Servo library).
 */
#include "config.h"

#if FS_OUTPUT_MODE == FS_OUTPUT_PINS

#include <Arduino.h>
#include <avr/interrupt.h>

#include "output.h"

namespace {

const uint16_t TICKS_PER_US = 2;
const uint16_t FRAME_TICKS = 20000 * TICKS_PER_US;
const uint16_t MIN_GAP_TICKS = 16;

volatile uint16_t pulse_ticks[FS_PIN_CHANNELS];
volatile int8_t channel = -1;
volatile uint16_t frame_start;

/* Channel c is pin 2 + c: D2..D7 are PD2..PD7, D8..D13 are PB0..PB5. */
inline void pin_write(int8_t c, bool high)
{
    if (c < 6) {
        uint8_t bit = (uint8_t)(1 << (c + 2));
        if (high) {
            PORTD |= bit;
        } else {
            PORTD &= (uint8_t)~bit;
        }
    } else {
        uint8_t bit = (uint8_t)(1 << (c - 6));
        if (high) {
            PORTB |= bit;
        } else {
            PORTB &= (uint8_t)~bit;
        }
    }
}

}  // namespace

ISR(TIMER1_COMPA_vect)
{
    if (channel >= 0) {
        pin_write(channel, false);
    }
    channel++;
    if (channel < FS_PIN_CHANNELS) {
        pin_write(channel, true);
        OCR1A += pulse_ticks[channel];
        return;
    }
    uint16_t next = (uint16_t)(frame_start + FRAME_TICKS);
    uint16_t ahead = (uint16_t)(next - TCNT1);
    if (ahead > FRAME_TICKS || ahead < MIN_GAP_TICKS) {
        next = (uint16_t)(TCNT1 + MIN_GAP_TICKS); /* frame overran: start the next one now */
    }
    OCR1A = next;
    frame_start = next;
    channel = -1;
}

uint8_t output_channels(void)
{
    return FS_PIN_CHANNELS;
}

bool output_begin(void)
{
    for (uint8_t c = 0; c < FS_PIN_CHANNELS; c++) {
        pinMode(FS_PIN_FIRST + c, OUTPUT);
        digitalWrite(FS_PIN_FIRST + c, LOW);
        pulse_ticks[c] = FS_US_DEFAULT_NEUTRAL * TICKS_PER_US;
    }
    uint8_t sreg = SREG;
    cli();
    TCCR1A = 0;           /* normal mode (the core set Timer1 up for analogWrite) */
    TCCR1B = _BV(CS11);   /* clk / 8 */
    frame_start = (uint16_t)(TCNT1 + 100);
    OCR1A = frame_start;
    TIFR1 = _BV(OCF1A);
    TIMSK1 = _BV(OCIE1A);
    SREG = sreg;
    return true;
}

bool output_write(const uint16_t *us, uint16_t mask)
{
    for (uint8_t c = 0; c < FS_PIN_CHANNELS; c++) {
        if (mask & (1U << c)) {
            uint16_t ticks = (uint16_t)(us[c] * TICKS_PER_US);
            uint8_t sreg = SREG;
            cli();
            pulse_ticks[c] = ticks;
            SREG = sreg;
        }
    }
    return true;
}

#endif
