/*
 * Servo output on a PCA9685 16-channel PWM board over I2C (Wire), 50 Hz.
 *
 * Registers (datasheet): MODE1 0x00 (SLEEP bit 4, AI = auto-increment bit 5, RESTART bit 7),
 * MODE2 0x01, LEDn_ON_L/ON_H/OFF_L/OFF_H at 0x06 + 4n, PRE_SCALE 0xFE (only written while
 * asleep). One tick is (PRE_SCALE + 1) / 25 MHz = 4.88 us at PRE_SCALE 121.
 */
#include "config.h"

#if FS_OUTPUT_MODE == FS_OUTPUT_PCA9685

#include <Arduino.h>
#include <Wire.h>

#include "output.h"

namespace {

const uint8_t REG_MODE1 = 0x00;
const uint8_t REG_MODE2 = 0x01;
const uint8_t REG_LED0_ON_L = 0x06;
const uint8_t REG_PRE_SCALE = 0xFE;
const uint8_t MODE1_AI = 0x20;
const uint8_t MODE1_SLEEP = 0x10;
const uint8_t MODE2_OUTDRV = 0x04;
/* Wire's buffer is 32 bytes: register address + 7 channels of 4 bytes. */
const uint8_t CHANNELS_PER_WRITE = 7;

bool write_register(uint8_t reg, uint8_t value)
{
    Wire.beginTransmission(FS_PCA9685_ADDRESS);
    Wire.write(reg);
    Wire.write(value);
    return Wire.endTransmission() == 0;
}

/* Ticks per microsecond, OSC / ((PRE_SCALE + 1) * 1e6), in 12.20 fixed point: a multiply and a
 * shift instead of a 32-bit division (about 40 us each on the AVR); off from exact rounding by
 * at most 0.002 tick over 0..2500 us. */
const uint32_t TICKS_PER_US_Q20 =
    (uint32_t)(((uint64_t)FS_PCA9685_OSC_HZ * (1UL << 20) + (FS_PCA9685_PRESCALE + 1) * 500000ULL) /
               ((FS_PCA9685_PRESCALE + 1) * 1000000ULL));

uint16_t ticks_for(uint16_t us)
{
    return (uint16_t)(((uint32_t)us * TICKS_PER_US_Q20 + (1UL << 19)) >> 20);
}

}  // namespace

uint8_t output_channels(void)
{
    return 16;
}

bool output_begin(void)
{
    Wire.begin();
    Wire.setClock(FS_I2C_HZ);
    Wire.setWireTimeout(FS_I2C_TIMEOUT_US, true);
    bool ok = write_register(REG_MODE1, MODE1_SLEEP | MODE1_AI);
    ok = ok && write_register(REG_PRE_SCALE, FS_PCA9685_PRESCALE);
    ok = ok && write_register(REG_MODE2, MODE2_OUTDRV);
    ok = ok && write_register(REG_MODE1, MODE1_AI); /* wake up */
    delayMicroseconds(500);                         /* oscillator start-up */
    return ok;
}

bool output_write(const uint16_t *us, uint16_t mask)
{
    bool ok = true;
    uint8_t ch = 0;
    while (ch < 16) {
        if (!(mask & (1U << ch))) {
            ch++;
            continue;
        }
        Wire.beginTransmission(FS_PCA9685_ADDRESS);
        Wire.write((uint8_t)(REG_LED0_ON_L + 4 * ch));
        uint8_t n = 0;
        while (ch < 16 && n < CHANNELS_PER_WRITE && (mask & (1U << ch))) {
            uint16_t on = (uint16_t)ch * FS_PCA9685_STAGGER;
            uint16_t off = (uint16_t)(on + ticks_for(us[ch]));
            uint8_t regs[4] = {(uint8_t)on, (uint8_t)(on >> 8), (uint8_t)off, (uint8_t)(off >> 8)};
            Wire.write(regs, sizeof(regs));
            ch++;
            n++;
        }
        ok = (Wire.endTransmission() == 0) && ok;
    }
    return ok;
}

#endif
