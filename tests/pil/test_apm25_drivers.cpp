// Register-level tests of the APM 2.5 board drivers on simavr (apm25_driver_smoke.elf, which reports on
// UART0 what the drivers return). simavr emulates the ATmega2560's timers, SPI and TWI but none of the
// board's parts, so:
// - Apm25Drivers (empty buses, as simavr alone): the ESC outputs' timer configuration (490 Hz, pulse
//   widths for given commands, output pins), the PPM decoder fed with a PPM-sum waveform on ICP5, and
//   the bring-up without sensors (reported absent, no samples).
// - Apm25DriversSensors: emulated MPU-6000 (SPI) and HMC5883L (TWI) slaves (emulated_parts.h) attached
//   before the AVR runs; the real drivers' configuration sequences, bus settings, identity checks,
//   sample decoding (axes, signs, scale) and read rates.
#include <simavr/avr_timer.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "emulated_parts.h"

extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }  // simavr's loader leaks

namespace {

constexpr double kF = 16e6;
constexpr avr_cycle_count_t kCyclesPerMs = 16000;

// The smoke image's UART0 frames (driver_smoke.cpp): 0xB0 init result, 0xA5 RC frame, 0xB1 IMU sample,
// 0xB2 mag sample.
struct Frames {
  std::vector<uint8_t> init;                      // init_board() results
  std::vector<std::vector<uint16_t>> rc;          // pulse widths per RC frame
  std::vector<std::array<float, 6>> imu;          // accel x, y, z, gyro x, y, z
  std::vector<std::array<float, 3>> mag;          // field x, y, z
  std::string error;                              // an unknown frame type
};

Frames parse(const std::vector<uint8_t>& s) {
  Frames f;
  auto floats = [&](size_t at, float* out, int n) { std::memcpy(out, &s[at], 4 * static_cast<size_t>(n)); };
  size_t i = 0;
  while (i < s.size()) {
    const uint8_t type = s[i];
    size_t length = 0;
    if (type == 0xB0) length = 2;
    else if (type == 0xB1) length = 25;
    else if (type == 0xB2) length = 13;
    else if (type == 0xA5 && i + 1 < s.size()) length = 2 + 2 * static_cast<size_t>(s[i + 1]);
    else if (type == 0xA5) break;  // the count byte is still on the line
    else {
      f.error = "unknown frame type " + std::to_string(type) + " at byte " + std::to_string(i);
      break;
    }
    if (i + length > s.size()) break;  // the rest of this frame is still on the line
    if (type == 0xB0) {
      f.init.push_back(s[i + 1]);
    } else if (type == 0xB1) {
      f.imu.emplace_back();
      floats(i + 1, f.imu.back().data(), 6);
    } else if (type == 0xB2) {
      f.mag.emplace_back();
      floats(i + 1, f.mag.back().data(), 3);
    } else {
      std::vector<uint16_t> pulses;
      for (size_t c = 0; c < s[i + 1]; ++c) pulses.push_back(static_cast<uint16_t>(s[i + 2 + 2 * c] | (s[i + 3 + 2 * c] << 8)));
      f.rc.push_back(pulses);
    }
    i += length;
  }
  return f;
}

struct Board {
  avr_t* avr = nullptr;
  std::vector<uint8_t> uart0;
  avr_irq_t* icp = nullptr;
  parts::Simavr16TwiFix twi_fix;  // the TWI master as the datasheet has it (emulated_parts.h)

  bool load() {
    avr = parts::load_atmega2560(DRIVER_SMOKE_ELF);
    if (!avr) return false;
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(
        avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
        [](avr_irq_t*, uint32_t value, void* self) { static_cast<Board*>(self)->uart0.push_back(static_cast<uint8_t>(value)); },
        this);
    icp = avr_io_getirq(avr, AVR_IOCTL_TIMER_GETIRQ('5'), TIMER_IRQ_IN_ICP);
    return icp != nullptr && twi_fix.attach(avr);
  }
  void run_until_cycle(avr_cycle_count_t cycle) {
    while (avr->cycle < cycle) {
      const int state = avr_run(avr);
      ASSERT_NE(state, cpu_Crashed);
    }
  }
  void run_ms(double ms) { run_until_cycle(avr->cycle + static_cast<avr_cycle_count_t>(ms * kCyclesPerMs)); }
  // Up to 1 s of AVR time for the bring-up (the MPU-6000 reset wait, the I2C timeouts), until the image
  // signals its motor write on GPIOR0; then until its init frame is on the line.
  void bring_up() {
    while (reg8(0x3E) != 1 && avr->cycle < 16000000u) {
      ASSERT_NE(avr_run(avr), cpu_Crashed);
    }
    ASSERT_EQ(reg8(0x3E), 1) << "the image did not reach its motor write (GPIOR0)";
    const avr_cycle_count_t limit = avr->cycle + kCyclesPerMs;
    while (uart0.size() < 2 && avr->cycle < limit) {
      ASSERT_NE(avr_run(avr), cpu_Crashed);
    }
  }
  Frames frames() const { return parse(uart0); }
  uint8_t reg8(uint16_t address) const { return avr->data[address]; }
  uint16_t reg16(uint16_t low) const { return static_cast<uint16_t>(avr->data[low] | (avr->data[low + 1] << 8)); }
};

class Apm25Drivers : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(board_.load()) << "cannot load " << DRIVER_SMOKE_ELF << " (make avr)";
    ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  }
  Board board_;
};

TEST_F(Apm25Drivers, EscOutputsAt490HzWithTheCommandedPulses) {
  // Timer1 and Timer4: fast PWM mode 14 (WGM 1110, TOP = ICR), prescaler 8, non-inverting outputs.
  for (const uint16_t base : {0x80, 0xA0}) {
    const uint8_t a = board_.reg8(base), b = board_.reg8(base + 1);
    EXPECT_EQ(a & 0x03, 0x02) << std::hex << base;         // WGMn1:0 = 10
    EXPECT_EQ((b >> 3) & 0x03, 0x03) << std::hex << base;  // WGMn3:2 = 11
    EXPECT_EQ(b & 0x07, 0x02) << std::hex << base;         // CSn = 010: F_CPU / 8
  }
  EXPECT_EQ(board_.reg8(0x80) & 0xF0, 0xA0);  // COM1A1, COM1B1
  EXPECT_EQ(board_.reg8(0xA0) & 0x3C, 0x28);  // COM4B1, COM4C1
  const uint16_t top1 = board_.reg16(0x86), top4 = board_.reg16(0xA6);
  EXPECT_EQ(top1, top4);
  EXPECT_NEAR(kF / 8.0 / (top1 + 1.0), 490.0, 0.5);
  // Pulses (2 ticks per us): OUT1 0 -> 1000 us, OUT2 0.25 -> 1250, OUT3 0.5 -> 1500, OUT4 1 -> 2000.
  EXPECT_EQ(board_.reg16(0x8A), 2000);  // OCR1B: OUT1
  EXPECT_EQ(board_.reg16(0x88), 2500);  // OCR1A: OUT2
  EXPECT_EQ(board_.reg16(0xAC), 3000);  // OCR4C: OUT3
  EXPECT_EQ(board_.reg16(0xAA), 4000);  // OCR4B: OUT4
  EXPECT_EQ(board_.reg8(0x24) & 0x60, 0x60);   // DDRB: PB5, PB6 outputs
  EXPECT_EQ(board_.reg8(0x101) & 0x30, 0x30);  // DDRH: PH4, PH5 outputs
}

// The PPM waveform as a chain of simavr cycle timers, so each rising edge on ICP5 happens at its exact
// cycle even while the AVR sleeps (a sleeping simavr core jumps to the next timer deadline).
struct PpmSource {
  avr_irq_t* icp = nullptr;
  std::vector<avr_cycle_count_t> gaps;  // cycles before each edge
  size_t next = 0;

  static avr_cycle_count_t fire(avr_t*, avr_cycle_count_t when, void* param) {
    auto* self = static_cast<PpmSource*>(param);
    avr_raise_irq(self->icp, 0);
    avr_raise_irq(self->icp, 1);
    if (++self->next >= self->gaps.size()) return 0;
    return when + self->gaps[self->next];
  }
};

TEST_F(Apm25Drivers, PpmFramesAreDecoded) {
  // Three PPM-sum frames: a 6 ms sync gap, then eight channels; one rising edge per boundary.
  const uint16_t channels[8] = {1100, 1200, 1300, 1400, 1500, 1600, 1700, 1800};
  PpmSource ppm;
  ppm.icp = board_.icp;
  auto us = [](double v) { return static_cast<avr_cycle_count_t>(v * 16.0); };
  ppm.gaps.push_back(us(1000));
  for (int frame = 0; frame < 3; ++frame) {
    ppm.gaps.push_back(us(6000));
    for (const uint16_t c : channels) ppm.gaps.push_back(us(c));
  }
  ppm.gaps.push_back(us(6000));  // the gap after the last frame ends it
  avr_cycle_count_t total = 0;
  for (const avr_cycle_count_t g : ppm.gaps) total += g;
  avr_cycle_timer_register(board_.avr, ppm.gaps[0], &PpmSource::fire, &ppm);
  board_.run_until_cycle(board_.avr->cycle + total + us(5000));
  // Frames are published at the sync gap after them: the first gap only synchronises.
  const Frames f = board_.frames();
  ASSERT_EQ(f.error, "");
  ASSERT_FALSE(f.rc.empty()) << "no RC frame reported";
  for (size_t frame = 0; frame < f.rc.size(); ++frame) {
    ASSERT_EQ(f.rc[frame].size(), 8u);
    for (int c = 0; c < 8; ++c) EXPECT_NEAR(f.rc[frame][c], channels[c], 1) << "frame " << frame << " channel " << c;
  }
  EXPECT_EQ(f.rc.size(), 3u);
}

TEST_F(Apm25Drivers, EmptyBusesReportTheSensorsAbsentAndNoSamples) {
  board_.run_ms(100);
  const Frames f = board_.frames();
  ASSERT_EQ(f.error, "");
  EXPECT_EQ(f.init, std::vector<uint8_t>{0});
  EXPECT_TRUE(f.imu.empty());
  EXPECT_TRUE(f.mag.empty());
}

// ---- With the emulated MPU-6000 and HMC5883L on the buses ----

constexpr float kG = 9.80665f;
constexpr double kAccelLsb = 9.80665 / 4096.0;            // +-8 g: 4096 LSB per g
constexpr double kGyroLsb = 3.14159265358979 / 180.0 / 16.4;  // +-2000 deg/s: 16.4 LSB per deg/s
constexpr double kGaussLsb = 1.0 / 1090.0;                // +-1.3 Ga: 1090 LSB per gauss

bool spi_mode3_master_msb_first(uint8_t spcr) {
  using namespace parts;
  return (spcr & (kSpe | kMstr | kCpol | kCpha | kDord)) == (kSpe | kMstr | kCpol | kCpha);
}

class Apm25DriversSensors : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(board_.load()) << "cannot load " << DRIVER_SMOKE_ELF << " (make avr)";
    ASSERT_TRUE(mpu_.attach(board_.avr)) << "no SPI or port B IRQs";
    ASSERT_TRUE(hmc_.attach(board_.avr)) << "no TWI IRQs";
  }
  Board board_;
  parts::Mpu6000 mpu_;
  parts::Hmc5883l hmc_;
};

TEST_F(Apm25DriversSensors, Mpu6000IsResetAndConfiguredOverSlowMode3Spi) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  EXPECT_EQ(board_.frames().init, std::vector<uint8_t>{1});

  // The register writes, in order: device reset, signal path reset (gyro, accel, temperature: the
  // register map's SPI reset sequence), I2C_IF_DIS (SPI only), clock from the z gyro's PLL (also clears
  // SLEEP), SMPLRT_DIV 0 (1 kHz), CONFIG DLPF_CFG 4 (20 Hz), GYRO_CONFIG FS_SEL 3 (+-2000 deg/s),
  // ACCEL_CONFIG AFS_SEL 2 (+-8 g), INT_ENABLE DATA_RDY_EN.
  const std::vector<std::pair<int, int>> expected = {{0x6B, 0x80}, {0x68, 0x07}, {0x6A, 0x10}, {0x6B, 0x03},
                                                     {0x19, 0x00}, {0x1A, 0x04}, {0x1B, 0x18}, {0x1C, 0x10},
                                                     {0x38, 0x01}};
  std::vector<std::pair<int, int>> written;
  for (const auto& w : mpu_.writes) written.emplace_back(w.reg, w.value);
  EXPECT_EQ(written, expected);
  // Every configuration transfer in SPI mode 3 (CPOL = CPHA = 1), master, MSB first, at most 1 MHz
  // (the MPU-6000's limit for all but the sensor and interrupt registers): F_CPU / 16.
  for (const auto& w : mpu_.writes) {
    EXPECT_TRUE(spi_mode3_master_msb_first(w.spcr)) << std::hex << "SPCR " << int(w.spcr) << " writing " << int(w.reg);
    EXPECT_EQ(parts::spi_clock_hz(w.spcr, w.spsr, kF), 1e6) << std::hex << "writing " << int(w.reg);
  }
  // One register per transaction here; every transaction with the other SPI devices deselected, the
  // clock unchanged within it.
  for (const auto& t : mpu_.transactions) {
    EXPECT_TRUE(t.others_deselected) << "baro or DataFlash selected during an MPU-6000 transfer";
    EXPECT_FALSE(t.clock_changed);
  }
  // The device reset and the signal path reset each get their 100 ms before the next access.
  ASSERT_GE(mpu_.transactions.size(), 3u);
  EXPECT_EQ(mpu_.transactions[0].mosi, (std::vector<uint8_t>{0x6B, 0x80}));
  EXPECT_EQ(mpu_.transactions[1].mosi, (std::vector<uint8_t>{0x68, 0x07}));
  EXPECT_GE(mpu_.transactions[1].cycle - mpu_.transactions[0].cycle, 100 * kCyclesPerMs);
  EXPECT_GE(mpu_.transactions[2].cycle - mpu_.transactions[1].cycle, 100 * kCyclesPerMs);
  // WHO_AM_I read (slow) after the clock selection and before the configuration.
  size_t who = 0;
  for (size_t i = 0; i < mpu_.transactions.size(); ++i) {
    if (!mpu_.transactions[i].mosi.empty() && mpu_.transactions[i].mosi[0] == (0x80 | 0x75)) {
      who = i;
      break;
    }
  }
  ASSERT_EQ(who, 4u) << "WHO_AM_I not read after the resets, USER_CTRL, PWR_MGMT_1";
  EXPECT_EQ(mpu_.transactions[who].mosi.size(), 2u);
  EXPECT_EQ(mpu_.transactions[who].miso.back(), 0x68);
  EXPECT_EQ(parts::spi_clock_hz(mpu_.transactions[who].spcr, mpu_.transactions[who].spsr, kF), 1e6);
  // The part ends up configured and awake.
  EXPECT_EQ(mpu_.reg[0x6B], 0x03);
  EXPECT_EQ(mpu_.reg[0x6A], 0x10);
  EXPECT_EQ(mpu_.reg[0x1A] & 0x07, 4);
  EXPECT_EQ(mpu_.reg[0x1B], 3 << 3);
  EXPECT_EQ(mpu_.reg[0x1C], 2 << 3);
  EXPECT_EQ(mpu_.reg[0x38], 0x01);
}

TEST_F(Apm25DriversSensors, Mpu6000WithAnotherWhoAmIIsAbsentAndSilent) {
  mpu_.who_am_i = 0x70;  // an MPU-6500
  mpu_.power_on();
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  EXPECT_EQ(board_.frames().init, std::vector<uint8_t>{0});
  // The resets, USER_CTRL, PWR_MGMT_1, then WHO_AM_I: no configuration of a part the driver does not know.
  EXPECT_EQ(mpu_.writes.size(), 4u);
  const size_t transactions = mpu_.transactions.size();
  EXPECT_EQ(transactions, 5u);
  // Whatever the part says, the driver reports no sample (DATA_RDY forced: the part is not configured).
  mpu_.set_raw({{1000, -2000, 4096}, 0, {164, -328, 16}});
  mpu_.reg[parts::Mpu6000::kIntStatus] = 0x01;
  ASSERT_TRUE(hmc_.publish(100, 200, 300));
  board_.run_ms(50);
  const Frames f = board_.frames();
  ASSERT_EQ(f.error, "");
  EXPECT_TRUE(f.imu.empty());
  EXPECT_EQ(mpu_.transactions.size(), transactions) << "imu_read() accessed an absent part";
  EXPECT_FALSE(f.mag.empty()) << "the compass stopped working with the IMU absent";
}

TEST_F(Apm25DriversSensors, Mpu6000SampleIsOneFastBurstMappedToFrdAndScaled) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  const size_t writes = mpu_.writes.size();
  const size_t before = mpu_.transactions.size();
  // Distinct magnitudes and signs per axis; the temperature between accel and gyro.
  const parts::Mpu6000::Raw raw{{1000, -2000, 4096}, -1234, {164, -328, 16}};
  ASSERT_TRUE(mpu_.publish(raw)) << "the part is asleep or its data-ready interrupt disabled";
  board_.run_ms(10);
  const Frames f = board_.frames();
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.imu.size(), 1u) << "one sample per DATA_RDY";
  // Body FRD from the sensor axes: x_body = y_sensor, y_body = x_sensor, z_body = -z_sensor.
  const std::array<float, 6>& s = f.imu[0];
  EXPECT_FLOAT_EQ(s[0], static_cast<float>(-2000 * kAccelLsb));
  EXPECT_FLOAT_EQ(s[1], static_cast<float>(1000 * kAccelLsb));
  EXPECT_FLOAT_EQ(s[2], static_cast<float>(-4096 * kAccelLsb));
  EXPECT_FLOAT_EQ(s[3], static_cast<float>(-328 * kGyroLsb));
  EXPECT_FLOAT_EQ(s[4], static_cast<float>(164 * kGyroLsb));
  EXPECT_FLOAT_EQ(s[5], static_cast<float>(-16 * kGyroLsb));
  // The driver polls with bursts: CS low once, 0x3A | read, 15 bytes (INT_STATUS, accel, temp, gyro),
  // mode 3 at F_CPU / 2 = 8 MHz (the sensor and interrupt registers take up to 20 MHz); no writes.
  ASSERT_GT(mpu_.transactions.size(), before);
  size_t first = before;  // a burst may have been running when the sample was published
  if (mpu_.transactions[before - 1].mosi[0] == (0x80 | 0x3A)) first = before - 1;
  size_t saw_data_ready = 0;
  for (size_t i = first; i < mpu_.transactions.size(); ++i) {
    const auto& t = mpu_.transactions[i];
    if (!t.done) continue;  // the burst still running when the run stopped
    ASSERT_EQ(t.mosi.size(), 16u) << "transaction " << i;
    if (t.miso[1] & 0x01) ++saw_data_ready;
    EXPECT_EQ(t.mosi[0], 0x80 | 0x3A);
    EXPECT_TRUE(spi_mode3_master_msb_first(t.spcr));
    EXPECT_EQ(parts::spi_clock_hz(t.spcr, t.spsr, kF), 8e6);
    EXPECT_FALSE(t.clock_changed);
    EXPECT_TRUE(t.others_deselected);
  }
  EXPECT_EQ(saw_data_ready, 1u) << "the sample came from one burst, which cleared DATA_RDY";
  EXPECT_EQ(mpu_.writes.size(), writes);
}

TEST_F(Apm25DriversSensors, Mpu6000WithoutDataReadyReportsNothing) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  const size_t before = mpu_.transactions.size();
  mpu_.set_raw({{1000, -2000, 4096}, 0, {164, -328, 16}});  // data, but DATA_RDY_INT clear
  board_.run_ms(20);
  EXPECT_GE(mpu_.transactions.size(), before + 3) << "the driver should keep polling";
  const Frames f = board_.frames();
  ASSERT_EQ(f.error, "");
  EXPECT_TRUE(f.imu.empty());
  // A second DATA_RDY gives exactly one more sample: INT_STATUS clears when read.
  ASSERT_TRUE(mpu_.publish({{1, 2, 3}, 0, {4, 5, 6}}));
  board_.run_ms(20);
  EXPECT_EQ(board_.frames().imu.size(), 1u);
}

TEST_F(Apm25DriversSensors, LevelBoardAtRestReadsMinusGOnBodyZ) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  // Level and still: 1 g up on the sensor's z axis, no rotation.
  ASSERT_TRUE(mpu_.publish({{0, 0, 4096}, 0, {0, 0, 0}}));
  board_.run_ms(10);
  const Frames f = board_.frames();
  ASSERT_EQ(f.imu.size(), 1u);
  // Specific force in FRD: (0, 0, -g) (hal.h's contract), zero rate.
  EXPECT_EQ(f.imu[0][0], 0.0f);
  EXPECT_EQ(f.imu[0][1], 0.0f);
  EXPECT_FLOAT_EQ(f.imu[0][2], -kG);
  for (int i = 3; i < 6; ++i) EXPECT_EQ(f.imu[0][i], 0.0f) << i;
}

TEST_F(Apm25DriversSensors, Hmc5883lIdentifiedAndConfiguredAt400kHz) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  EXPECT_EQ(board_.frames().init, std::vector<uint8_t>{1});
  // CRA 0x78: MA = 11 (8-sample average), DO = 110 (75 Hz), normal measurement; CRB 0x20: GN = 001
  // (1090 LSB/gauss); mode 0x00: continuous measurement.
  std::vector<std::pair<int, int>> written;
  for (const auto& w : hmc_.writes) written.emplace_back(w.reg, w.value);
  EXPECT_EQ(written, (std::vector<std::pair<int, int>>{{0x00, 0x78}, {0x01, 0x20}, {0x02, 0x00}}));
  EXPECT_EQ(hmc_.reg[0x00], 0x78);
  EXPECT_EQ(hmc_.reg[0x01], 0x20);
  EXPECT_EQ(hmc_.reg[0x02], 0x00);
  // First the identity: pointer to 0x0A, repeated start, three bytes read, the last one not acknowledged.
  ASSERT_GE(hmc_.transfers.size(), 5u);
  EXPECT_FALSE(hmc_.transfers[0].read);
  EXPECT_EQ(hmc_.transfers[0].data, std::vector<uint8_t>{0x0A});
  EXPECT_FALSE(hmc_.transfers[0].stopped) << "pointer write and read joined by a repeated start";
  EXPECT_TRUE(hmc_.transfers[1].read);
  EXPECT_EQ(hmc_.transfers[1].data, (std::vector<uint8_t>{'H', '4', '3'}));
  EXPECT_EQ(hmc_.transfers[1].master_ack, (std::vector<bool>{true, true, false}));
  EXPECT_TRUE(hmc_.transfers[1].stopped);
  // Then one register per write transfer, each ended by a STOP.
  for (size_t i = 2; i < 5; ++i) {
    EXPECT_FALSE(hmc_.transfers[i].read);
    EXPECT_EQ(hmc_.transfers[i].data.size(), 2u);
    EXPECT_TRUE(hmc_.transfers[i].stopped);
  }
  // SCL 400 kHz (the part's maximum): TWBR 12, prescaler 1, on every transfer.
  for (const auto& t : hmc_.transfers) {
    EXPECT_EQ(t.twbr, 12);
    EXPECT_EQ(t.twsr, 0);
    EXPECT_EQ(parts::twi_clock_hz(t.twbr, t.twsr, kF), 400e3);
  }
}

TEST(Apm25DriversSensorsId, Hmc5883lWithAnotherIdIsAbsentAndSilent) {
  // Each identification byte checked: one wrong byte is another part.
  for (const std::array<uint8_t, 3>& id :
       {std::array<uint8_t, 3>{{'X', '4', '3'}}, std::array<uint8_t, 3>{{'H', 'X', '3'}},
        std::array<uint8_t, 3>{{'H', '4', 'X'}}}) {
    SCOPED_TRACE(std::string(id.begin(), id.end()));
    Board board;
    parts::Mpu6000 mpu;
    parts::Hmc5883l hmc;
    ASSERT_TRUE(board.load());
    ASSERT_TRUE(mpu.attach(board.avr));
    ASSERT_TRUE(hmc.attach(board.avr));
    hmc.id = id;
    hmc.power_on();
    ASSERT_NO_FATAL_FAILURE(board.bring_up());
    EXPECT_EQ(board.frames().init, std::vector<uint8_t>{0});
    EXPECT_TRUE(hmc.writes.empty()) << "a part with another identity was configured";
    hmc.set_raw(100, 200, 300);
    ASSERT_TRUE(mpu.publish({{0, 0, 4096}, 0, {0, 0, 0}}));
    board.run_ms(100);
    const Frames f = board.frames();
    ASSERT_EQ(f.error, "");
    EXPECT_TRUE(f.mag.empty());
    EXPECT_TRUE(hmc.data_reads.empty());
    EXPECT_EQ(f.imu.size(), 1u) << "the IMU stopped working with the compass absent";
  }
}

TEST_F(Apm25DriversSensors, Hmc5883lXzyRegistersGiveTheFieldInGauss) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  const size_t before = hmc_.transfers.size();
  // Distinct magnitudes and signs per axis: x 300, y -1234, z 1500 LSB (registers in X, Z, Y order).
  ASSERT_TRUE(hmc_.publish(300, -1234, 1500)) << "the part is not in continuous mode";
  EXPECT_EQ(hmc_.reg[0x05], 1500 >> 8);  // Z MSB comes before Y
  board_.run_ms(40);
  const Frames f = board_.frames();
  ASSERT_EQ(f.error, "");
  ASSERT_GE(f.mag.size(), 2u);
  for (const auto& m : f.mag) {
    EXPECT_FLOAT_EQ(m[0], static_cast<float>(300 * kGaussLsb));
    EXPECT_FLOAT_EQ(m[1], static_cast<float>(-1234 * kGaussLsb));
    EXPECT_FLOAT_EQ(m[2], static_cast<float>(1500 * kGaussLsb));
  }
  // Each read: pointer 0x03, repeated start, six bytes, the last one not acknowledged, then STOP;
  // the part is left unlocked (all six data registers read).
  ASSERT_GE(hmc_.transfers.size(), before + 4);
  for (size_t i = before; i + 1 < hmc_.transfers.size(); i += 2) {
    const auto& w = hmc_.transfers[i];
    const auto& r = hmc_.transfers[i + 1];
    if (i + 2 == hmc_.transfers.size() && !r.stopped) break;  // still running when the run stopped
    EXPECT_FALSE(w.read);
    EXPECT_EQ(w.data, std::vector<uint8_t>{0x03});
    EXPECT_FALSE(w.stopped);
    EXPECT_TRUE(r.read);
    EXPECT_EQ(r.first_reg, 0x03);
    EXPECT_EQ(r.data.size(), 6u);
    EXPECT_EQ(r.master_ack, (std::vector<bool>{true, true, true, true, true, false}));
    EXPECT_TRUE(r.stopped);
  }
  EXPECT_FALSE(hmc_.locked());
  EXPECT_EQ(hmc_.writes.size(), 3u) << "no register writes after the configuration";
}

TEST_F(Apm25DriversSensors, Hmc5883lOverflowOnAnyAxisGivesNoSample) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  constexpr int16_t kOverflow = -4096;
  const int16_t cases[3][3] = {{kOverflow, 200, 300}, {100, kOverflow, 300}, {100, 200, kOverflow}};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::to_string(c[0]) + " " + std::to_string(c[1]) + " " + std::to_string(c[2]));
    const size_t samples = board_.frames().mag.size(), reads = hmc_.data_reads.size();
    ASSERT_TRUE(hmc_.publish(c[0], c[1], c[2]));
    board_.run_ms(40);
    EXPECT_GE(hmc_.data_reads.size(), reads + 2) << "the driver should keep reading";
    EXPECT_EQ(board_.frames().mag.size(), samples);
  }
  // A valid measurement again gives samples.
  const size_t samples = board_.frames().mag.size();
  ASSERT_TRUE(hmc_.publish(100, 200, 300));
  board_.run_ms(40);
  EXPECT_GE(board_.frames().mag.size(), samples + 2);
}

TEST_F(Apm25DriversSensors, Hmc5883lIsReadOnThePartsOwn75HzSchedule) {
  ASSERT_NO_FATAL_FAILURE(board_.bring_up());
  ASSERT_TRUE(hmc_.publish(100, 200, 300));
  const size_t before = hmc_.data_reads.size();
  board_.run_ms(1000);
  const std::vector<avr_cycle_count_t> reads(hmc_.data_reads.begin() + static_cast<long>(before),
                                             hmc_.data_reads.end());
  ASSERT_GE(reads.size(), 2u);
  // 75 reads a second, on the part's schedule (k x 13.33 ms from the configuration), each late only by
  // the main loop's iteration (its 1 ms idle plus simavr's slow SPI polling of the IMU, about 2.7 ms): a
  // driver timing each read from the last one would fall behind by that every time (66 Hz here, and
  // 50 Hz in a 100 Hz flight loop).
  EXPECT_GE(reads.size(), 74u);
  EXPECT_LE(reads.size(), 76u);
  for (size_t i = 1; i < reads.size(); ++i) {
    EXPECT_GE(reads[i] - reads[i - 1], static_cast<avr_cycle_count_t>(9.0 * kCyclesPerMs)) << "read " << i;
    EXPECT_LT(reads[i] - reads[i - 1], static_cast<avr_cycle_count_t>(17.7 * kCyclesPerMs)) << "read " << i;
  }
  const double mean_ms = static_cast<double>(reads.back() - reads.front()) / (reads.size() - 1) / kCyclesPerMs;
  EXPECT_NEAR(mean_ms, 1000.0 / 75.0, 0.1);
  // Every read gives a sample (the last one may still be on the UART).
  const size_t samples = board_.frames().mag.size();
  EXPECT_LE(samples, hmc_.data_reads.size());
  EXPECT_GE(samples + 1, hmc_.data_reads.size());
}

}  // namespace
