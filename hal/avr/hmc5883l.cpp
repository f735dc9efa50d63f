// Honeywell HMC5883L on the TWI bus (the APM 2.5's external compass): 75 Hz continuous measurement,
// 8-sample averaging, +-1.3 gauss (1090 LSB/gauss). The TWI transfers block, bounded by a timeout.
#include "board.h"
#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

constexpr uint8_t kAddress = 0x1E;
constexpr uint8_t kConfigA = 0x00, kConfigB = 0x01, kMode = 0x02, kDataXMsb = 0x03, kIdA = 0x0A;
constexpr uint8_t kAverage8Rate75Hz = (3 << 5) | (6 << 2);  // MA = 11 (8 samples), DO = 110 (75 Hz)
constexpr uint8_t kGain1_3Ga = 1 << 5;                       // GN = 001: 1090 LSB per gauss
constexpr uint8_t kContinuous = 0x00;
constexpr float kGaussPerLsb = 1.0f / 1090.0f;
constexpr int16_t kOverflow = -4096;            // the data registers' ADC overflow value
constexpr uint32_t kPeriodUs = 1000000u / 75u;  // one new averaged sample per output period

// TWI status codes (ATmega2560 datasheet, TWI chapter).
constexpr uint8_t kStart = 0x08, kRepStart = 0x10, kSlaWAck = 0x18, kDataWAck = 0x28, kSlaRAck = 0x40,
                  kDataRAck = 0x50, kDataRNack = 0x58;

bool wait_twint(uint8_t expected) {
  for (uint16_t spins = 0; !(TWCR & _BV(TWINT)); ++spins) {
    if (spins > 2000) return false;  // about a millisecond: a stuck bus or no device
  }
  return (TWSR & 0xF8) == expected;
}
bool start(uint8_t expected) {
  TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN);
  return wait_twint(expected);
}
bool send(uint8_t byte, uint8_t expected) {
  TWDR = byte;
  TWCR = _BV(TWINT) | _BV(TWEN);
  return wait_twint(expected);
}
// TWSTO clears itself once the STOP is on the bus; a START written before that would be lost, so the
// next transfer waits for it (bounded like wait_twint()).
void stop() {
  TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
  for (uint16_t spins = 0; (TWCR & _BV(TWSTO)) && spins <= 2000; ++spins) {
  }
}

bool write_register(uint8_t reg, uint8_t value) {
  const bool ok = start(kStart) && send(static_cast<uint8_t>(kAddress << 1), kSlaWAck) && send(reg, kDataWAck) &&
                  send(value, kDataWAck);
  stop();
  return ok;
}

bool read_registers(uint8_t first, uint8_t* out, uint8_t count) {
  bool ok = start(kStart) && send(static_cast<uint8_t>(kAddress << 1), kSlaWAck) && send(first, kDataWAck) &&
            start(kRepStart) && send(static_cast<uint8_t>((kAddress << 1) | 1), kSlaRAck);
  for (uint8_t i = 0; ok && i < count; ++i) {
    const bool last = i + 1 == count;
    TWCR = static_cast<uint8_t>(_BV(TWINT) | _BV(TWEN) | (last ? 0 : _BV(TWEA)));
    ok = wait_twint(last ? kDataRNack : kDataRAck);
    out[i] = TWDR;
  }
  stop();
  return ok;
}

int16_t be16(const uint8_t* p) { return static_cast<int16_t>((static_cast<uint16_t>(p[0]) << 8) | p[1]); }

bool g_present = false;
uint32_t g_next_read_us = 0;  // when the part's next averaged sample is due (75 Hz schedule)

}  // namespace

bool start_mag() {
  TWSR = 0;                                  // prescaler 1
  TWBR = (F_CPU / 400000u - 16u) / 2u;       // 400 kHz
  uint8_t id[3] = {0, 0, 0};
  if (!read_registers(kIdA, id, sizeof id) || id[0] != 'H' || id[1] != '4' || id[2] != '3') return false;
  g_present = write_register(kConfigA, kAverage8Rate75Hz) && write_register(kConfigB, kGain1_3Ga) &&
              write_register(kMode, kContinuous);
  g_next_read_us = micros() + kPeriodUs;
  return g_present;
}

}  // namespace avr

bool mag_read(MagSample& out) {
  if (!avr::g_present) return false;
  const uint32_t now = micros();
  if (static_cast<int32_t>(now - avr::g_next_read_us) < 0) return false;
  // On the part's 75 Hz schedule, not one period after the last read: a loop that comes by every 10 ms
  // (100 Hz) still reads 75 samples a second, not one per two iterations (50 Hz). A loop that fell a
  // whole period behind (a blocking storage write) starts the schedule again from now.
  avr::g_next_read_us += avr::kPeriodUs;
  if (static_cast<int32_t>(now - avr::g_next_read_us) >= 0) avr::g_next_read_us = now + avr::kPeriodUs;
  uint8_t raw[6];  // X, Z, Y (the HMC5883L's register order), big-endian
  if (!avr::read_registers(avr::kDataXMsb, raw, sizeof raw)) return false;
  const int16_t x = avr::be16(raw), z = avr::be16(raw + 2), y = avr::be16(raw + 4);
  if (x == avr::kOverflow || y == avr::kOverflow || z == avr::kOverflow) return false;
  // The compass module is mounted with its x axis forward, y right, z down (FRD); a module mounted
  // otherwise needs its rotation here.
  out.field = Vec3{x * avr::kGaussPerLsb, y * avr::kGaussPerLsb, z * avr::kGaussPerLsb};
  return true;
}

}  // namespace hal
}  // namespace quad
