// InvenSense MPU-6000 on the SPI bus (CS PB0): DLPF 20 Hz (thesis sec. 6.1.2), +-8 g, +-2000 deg/s,
// 1 kHz output rate, read in one burst together with INT_STATUS so no data-ready pin is needed.
#include <math.h>

#include "board.h"
#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

// Register map (MPU-6000 register map rev. 4.2).
constexpr uint8_t kSmplrtDiv = 0x19, kConfig = 0x1A, kGyroConfig = 0x1B, kAccelConfig = 0x1C, kIntEnable = 0x38,
                  kIntStatus = 0x3A, kSignalPathReset = 0x68, kUserCtrl = 0x6A, kPwrMgmt1 = 0x6B, kWhoAmI = 0x75;
constexpr uint8_t kReadFlag = 0x80, kWhoAmIValue = 0x68;
constexpr uint8_t kDlpf20Hz = 4;         // CONFIG.DLPF_CFG = 4: accel 21 Hz, gyro 20 Hz, 1 kHz internal rate
constexpr uint8_t kGyro2000Dps = 3 << 3;  // GYRO_CONFIG.FS_SEL = 3: 16.4 LSB per deg/s
constexpr uint8_t kAccel8G = 2 << 3;      // ACCEL_CONFIG.AFS_SEL = 2: 4096 LSB per g
constexpr float kAccelScale = 9.80665f / 4096.0f;                // m/s^2 per LSB
constexpr float kGyroScale = 3.14159265f / 180.0f / 16.4f;       // rad/s per LSB

// SPI mode 3, MSB first. The MPU-6000 takes at most 1 MHz for configuration, 20 MHz for the sensor
// and interrupt registers: F_CPU / 16 while configuring, F_CPU / 2 for the burst reads.
constexpr uint8_t kCs = _BV(PB0);

void spi_slow() {
  SPCR = _BV(SPE) | _BV(MSTR) | _BV(CPOL) | _BV(CPHA) | _BV(SPR0);
  SPSR = 0;
}
void spi_fast() {
  SPCR = _BV(SPE) | _BV(MSTR) | _BV(CPOL) | _BV(CPHA);
  SPSR = _BV(SPI2X);
}
uint8_t spi_transfer(uint8_t out) {
  SPDR = out;
  while (!(SPSR & _BV(SPIF))) {
  }
  return SPDR;
}
void select() { PORTB &= static_cast<uint8_t>(~kCs); }
void deselect() { PORTB |= kCs; }

void write_register(uint8_t reg, uint8_t value) {
  select();
  spi_transfer(reg);
  spi_transfer(value);
  deselect();
}
void read_registers(uint8_t first, uint8_t* out, uint8_t count) {
  select();
  spi_transfer(first | kReadFlag);
  for (uint8_t i = 0; i < count; ++i) out[i] = spi_transfer(0);
  deselect();
}

int16_t be16(const uint8_t* p) { return static_cast<int16_t>((static_cast<uint16_t>(p[0]) << 8) | p[1]); }

bool g_present = false;

}  // namespace

bool start_imu() {
  // Deselect every device on the bus (baro PG1, DataFlash PA6) before the first clock edge.
  PORTG |= _BV(PG1);
  DDRG |= _BV(PG1);
  PORTA |= _BV(PA6);
  DDRA |= _BV(PA6);
  deselect();
  DDRB |= kCs | _BV(PB1) | _BV(PB2);  // CS, SCK, MOSI out; MISO (PB3) in
  spi_slow();
  write_register(kPwrMgmt1, 0x80);  // device reset
  wait_us(100000);
  // Over SPI the register map (PWR_MGMT_1, DEVICE_RESET) asks for the signal paths to be reset too:
  // GYRO_RESET, ACCEL_RESET, TEMP_RESET, then another 100 ms.
  write_register(kSignalPathReset, 0x07);
  wait_us(100000);
  write_register(kUserCtrl, 0x10);  // I2C_IF_DIS: SPI only
  write_register(kPwrMgmt1, 0x03);  // clock from the z gyro's PLL
  wait_us(10000);
  uint8_t who = 0;
  read_registers(kWhoAmI, &who, 1);
  if (who != kWhoAmIValue) return false;
  write_register(kSmplrtDiv, 0);  // 1 kHz / (1 + 0): a fresh sample for any loop rate up to 1 kHz
  write_register(kConfig, kDlpf20Hz);
  write_register(kGyroConfig, kGyro2000Dps);
  write_register(kAccelConfig, kAccel8G);
  write_register(kIntEnable, 0x01);  // DATA_RDY_EN: sets INT_STATUS.DATA_RDY_INT, cleared by reading it
  spi_fast();
  g_present = true;
  return true;
}

}  // namespace avr

bool imu_read(ImuSample& out) {
  if (!avr::g_present) return false;
  // INT_STATUS, ACCEL_X..Z, TEMP, GYRO_X..Z: 15 consecutive registers from 0x3A.
  uint8_t raw[15];
  avr::read_registers(avr::kIntStatus, raw, sizeof raw);
  if (!(raw[0] & 0x01)) return false;
  // Sensor axes to the body frame FRD on the APM 2.5 (as ArduPilot's APM2 driver):
  // x_body = y_sensor, y_body = x_sensor, z_body = -z_sensor (a proper rotation: det = +1).
  const float ax = avr::be16(raw + 1), ay = avr::be16(raw + 3), az = avr::be16(raw + 5);
  const float gx = avr::be16(raw + 9), gy = avr::be16(raw + 11), gz = avr::be16(raw + 13);
  // The MPU-6000 reads +1 g on an axis pointing up; specific force in FRD is (0, 0, -g) when level.
  out.accel = Vec3{ay * avr::kAccelScale, ax * avr::kAccelScale, -az * avr::kAccelScale};
  out.gyro = Vec3{gy * avr::kGyroScale, gx * avr::kGyroScale, -gz * avr::kGyroScale};
  return true;
}

}  // namespace hal
}  // namespace quad
