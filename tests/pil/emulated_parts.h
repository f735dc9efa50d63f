// Emulated sensor parts of the APM 2.5 for test_apm25_drivers.cpp: the MPU-6000 on the SPI bus (chip
// select PB0) and the HMC5883L on the TWI bus (7-bit address 0x1E), at register level, as simavr 1.6
// slaves. They answer the real drivers (hal/avr/mpu6000.cpp, hmc5883l.cpp) running on the simulated
// ATmega2560 and record what the drivers did, so the tests can check it.
//
// simavr 1.6's bus protocols, as the slaves here use them:
// - SPI: a byte the master writes to SPDR appears on SPI_IRQ_OUTPUT 100 us later (simavr's fixed
//   transfer time, whatever the SPI clock), right after SPIF is set. A slave answers by raising
//   SPI_IRQ_INPUT from that notification: the value is what the master reads from SPDR for the same
//   transfer (full duplex). With no answer SPDR reads 0.
// - TWI: TWI_IRQ_OUTPUT carries avr_twi_msg_t messages: TWI_COND_START with the address byte (SLA+R/W)
//   when the master sends it (a repeated start is just another START), TWI_COND_WRITE with a data
//   byte, TWI_COND_READ when the master wants a byte (with TWI_COND_ACK when it will acknowledge it,
//   i.e. TWEA set), TWI_COND_STOP. The slave must answer within the notification on TWI_IRQ_INPUT:
//   TWI_COND_ACK with data bit 0 set to acknowledge an address or a written byte (no answer = NACK),
//   TWI_COND_READ with the data byte for a read. simavr sets the status (TWSR) 9 us after a data byte
//   or SLA+R, at once after SLA+W.
//   Simavr16TwiFix below corrects two bugs of simavr 1.6's TWI master that a polling driver trips on.
//
// Not modelled: the MPU-6000's start-up and reset times (the tests check the driver's waits instead),
// its FIFO, I2C interface, self-test, the sample timing (the test publishes samples); the HMC5883L's
// measurement timing and single-measurement mode, its DRDY pin, its self-test bias; bus electrical
// timing (simavr moves whole bytes).
#pragma once

#include <simavr/avr_ioport.h>
#include <simavr/avr_spi.h>
#include <simavr/avr_twi.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

namespace parts {

// An ATmega2560 at 16 MHz with the image of `elf` loaded, run as fast as the host allows (no wall-clock
// pacing); nullptr when the image or the part cannot be had.
inline avr_t* load_atmega2560(const char* elf) {
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf, &fw) != 0) return nullptr;
  avr_t* avr = avr_make_mcu_by_name("atmega2560");
  if (!avr) return nullptr;
  avr_init(avr);
  avr->frequency = 16000000;
  avr->sleep = [](avr_t*, avr_cycle_count_t) {};
  avr_load_firmware(avr, &fw);
  return avr;
}

// ATmega2560 data-space addresses of the registers the parts look at.
constexpr uint16_t kSpcr = 0x4C, kSpsr = 0x4D, kTwbr = 0xB8, kTwsr = 0xB9;
constexpr uint16_t kDdrA = 0x21, kPortA = 0x22, kDdrG = 0x33, kPortG = 0x34;

// SPCR bits.
constexpr uint8_t kSpe = 1 << 6, kDord = 1 << 5, kMstr = 1 << 4, kCpol = 1 << 3, kCpha = 1 << 2;

// The SPI clock for SPCR/SPSR (SPR1:0 divide by 4, 16, 64, 128; SPI2X in SPSR halves the divider).
inline double spi_clock_hz(uint8_t spcr, uint8_t spsr, double f_cpu) {
  static const double kDivider[4] = {4, 16, 64, 128};
  return f_cpu / (kDivider[spcr & 3] / ((spsr & 1) ? 2 : 1));
}

// The TWI clock for TWBR/TWSR: F_CPU / (16 + 2 TWBR 4^TWPS).
inline double twi_clock_hz(uint8_t twbr, uint8_t twsr, double f_cpu) {
  static const double kPrescaler[4] = {1, 4, 16, 64};
  return f_cpu / (16.0 + 2.0 * twbr * kPrescaler[twsr & 3]);
}

// An IRQ whose every raise must reach its hooks (a slave answering the same byte twice in a row).
inline avr_irq_t* unfiltered(avr_irq_t* irq) {
  if (irq) avr_irq_set_flags(irq, static_cast<uint8_t>(avr_irq_get_flags(irq) & ~IRQ_FLAG_FILTERED));
  return irq;
}

// Corrections to simavr 1.6's TWI master so it behaves as the ATmega2560 datasheet says for a driver that
// polls TWINT (hal/avr/hmc5883l.cpp); without them no polled transfer completes on simavr 1.6:
// - writing TWCR with TWINT set does not clear TWINT, so the driver's wait ends at once and it reads
//   the previous status (simavr issue #453; here TWINT is cleared when the master starts the address,
//   data or read transfer, which simavr announces on TWI_IRQ_OUTPUT, and set again with the status);
// - after SLA+W the status is 0x28/0x30 (data byte ACK/NACK) instead of 0x18/0x20 (simavr issue #137,
//   fixed after 1.6).
// Attach once per AVR, before it runs; harmless with or without slaves on the bus.
class Simavr16TwiFix {
 public:
  bool attach(avr_t* avr) {
    avr_ = avr;
    avr_irq_t* out = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT);
    avr_irq_t* status = unfiltered(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_STATUS));
    if (!out || !status) return false;
    avr_irq_register_notify(out, &Simavr16TwiFix::on_bus, this);
    avr_irq_register_notify(status, &Simavr16TwiFix::on_status, this);
    return true;
  }

 private:
  static constexpr uint16_t kTwcr = 0xBC;
  static constexpr uint8_t kTwint = 0x80;

  static void on_bus(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<Simavr16TwiFix*>(param);
    avr_twi_msg_irq_t m;
    m.u.v = value;
    if (m.u.twi.msg & (TWI_COND_START | TWI_COND_WRITE | TWI_COND_READ)) {
      self->avr_->data[kTwcr] = static_cast<uint8_t>(self->avr_->data[kTwcr] & ~kTwint);
    }
    self->after_sla_w_ = (m.u.twi.msg & TWI_COND_START) && !(m.u.twi.addr & 1);
  }
  static void on_status(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<Simavr16TwiFix*>(param);
    if (!self->after_sla_w_) return;
    self->after_sla_w_ = false;
    uint8_t& twsr = self->avr_->data[kTwsr];
    if (value == 0x28) twsr = static_cast<uint8_t>((twsr & 0x03) | 0x18);
    if (value == 0x30) twsr = static_cast<uint8_t>((twsr & 0x03) | 0x20);
  }

  avr_t* avr_ = nullptr;
  bool after_sla_w_ = false;
};

// InvenSense MPU-6000, SPI slave, chip select PB0 active low. A transaction is one CS-low period: its
// first byte is the register address with bit 7 set for a read, the following bytes read or write
// consecutive registers. Register file of 128 bytes, power-on values PWR_MGMT_1 = 0x40 (SLEEP),
// WHO_AM_I = who_am_i, all others 0; a PWR_MGMT_1 write with DEVICE_RESET (bit 7) restores them.
// INT_STATUS is cleared when read; the sensor data, INT_STATUS and WHO_AM_I are read-only.
class Mpu6000 {
 public:
  static constexpr uint8_t kIntStatus = 0x3A, kAccelXoutH = 0x3B, kIntEnable = 0x38, kPwrMgmt1 = 0x6B,
                           kWhoAmI = 0x75;

  struct Write {  // one register written, with the SPI configuration of its transfer
    uint8_t reg, value, spcr, spsr;
    avr_cycle_count_t cycle;
  };
  struct Transaction {  // one CS-low period
    std::vector<uint8_t> mosi, miso;
    uint8_t spcr = 0, spsr = 0;    // at the first byte
    bool clock_changed = false;    // SPCR or SPI2X changed within the transaction
    bool others_deselected = true;  // baro (PG1) and DataFlash (PA6) chip selects driven high throughout
    avr_cycle_count_t cycle = 0;   // of the first byte
    bool done = false;             // CS went high again
  };
  struct Raw {  // sensor outputs in LSB, as the registers 0x3B..0x48 hold them
    int16_t accel[3];
    int16_t temp;
    int16_t gyro[3];
  };

  uint8_t who_am_i = 0x68;  // another value stands for another part
  std::array<uint8_t, 128> reg{};
  std::vector<Write> writes;
  std::vector<Transaction> transactions;

  Mpu6000() { power_on(); }
  Mpu6000(const Mpu6000&) = delete;  // the simavr hooks hold `this`
  Mpu6000& operator=(const Mpu6000&) = delete;

  // Before the AVR runs. False when the IRQs cannot be found.
  bool attach(avr_t* avr) {
    avr_ = avr;
    avr_irq_t* cs = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_PIN0);
    avr_irq_t* mosi = avr_io_getirq(avr, AVR_IOCTL_SPI_GETIRQ(0), SPI_IRQ_OUTPUT);
    miso_ = unfiltered(avr_io_getirq(avr, AVR_IOCTL_SPI_GETIRQ(0), SPI_IRQ_INPUT));
    if (!cs || !mosi || !miso_) return false;
    avr_irq_register_notify(cs, &Mpu6000::on_cs, this);
    avr_irq_register_notify(mosi, &Mpu6000::on_mosi, this);
    return true;
  }

  void power_on() {
    reg.fill(0);
    reg[kPwrMgmt1] = 0x40;
    reg[kWhoAmI] = who_am_i;
  }

  // Sets the sensor registers (big-endian), without signalling data ready.
  void set_raw(const Raw& raw) {
    const int16_t words[7] = {raw.accel[0], raw.accel[1], raw.accel[2], raw.temp,
                              raw.gyro[0],  raw.gyro[1],  raw.gyro[2]};
    for (int i = 0; i < 7; ++i) {
      reg[kAccelXoutH + 2 * i] = static_cast<uint8_t>(static_cast<uint16_t>(words[i]) >> 8);
      reg[kAccelXoutH + 2 * i + 1] = static_cast<uint8_t>(words[i]);
    }
  }
  // A new sample as the part produces one: the sensor registers, then INT_STATUS.DATA_RDY_INT, which
  // the part sets only when awake (PWR_MGMT_1.SLEEP clear) with INT_ENABLE.DATA_RDY_EN set. Returns
  // whether DATA_RDY_INT was set.
  bool publish(const Raw& raw) {
    set_raw(raw);
    if ((reg[kPwrMgmt1] & 0x40) || !(reg[kIntEnable] & 0x01)) return false;
    reg[kIntStatus] |= 0x01;
    return true;
  }

 private:
  static bool read_only(uint8_t r) { return (r >= kIntStatus && r <= 0x60) || r == kWhoAmI; }

  static void on_cs(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<Mpu6000*>(param);
    const bool low = value == 0;
    if (low && !self->selected_) {
      self->transactions.emplace_back();
      self->transactions.back().cycle = self->avr_->cycle;
    } else if (!low && self->selected_) {
      self->transactions.back().done = true;
    }
    self->selected_ = low;
  }

  static void on_mosi(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<Mpu6000*>(param);
    if (!self->selected_) return;  // not for us: MISO stays released
    avr_t* avr = self->avr_;
    Transaction& t = self->transactions.back();
    const uint8_t spcr = avr->data[kSpcr], spsr = static_cast<uint8_t>(avr->data[kSpsr] & 0x01);
    if (t.mosi.empty()) {
      t.spcr = spcr;
      t.spsr = spsr;
      t.cycle = avr->cycle;
    } else if (spcr != t.spcr || spsr != t.spsr) {
      t.clock_changed = true;
    }
    const bool baro_high = (avr->data[kDdrG] & avr->data[kPortG] & 0x02) != 0;
    const bool flash_high = (avr->data[kDdrA] & avr->data[kPortA] & 0x40) != 0;
    if (!baro_high || !flash_high) t.others_deselected = false;

    const uint8_t byte = static_cast<uint8_t>(value);
    uint8_t reply = 0;
    if (t.mosi.empty()) {
      self->address_ = byte & 0x7F;
      self->reading_ = (byte & 0x80) != 0;
    } else {
      const uint8_t r = self->address_;
      self->address_ = static_cast<uint8_t>((r + 1) & 0x7F);
      if (self->reading_) {
        reply = self->reg[r];
        if (r == kIntStatus) self->reg[r] = 0;  // INT_STATUS clears when read
      } else {
        self->writes.push_back({r, byte, spcr, spsr, avr->cycle});
        if (r == kPwrMgmt1 && (byte & 0x80)) {
          self->power_on();  // DEVICE_RESET: all registers to their power-on values
        } else if (!read_only(r)) {
          self->reg[r] = byte;
        }
      }
    }
    t.mosi.push_back(byte);
    t.miso.push_back(reply);
    avr_raise_irq(self->miso_, reply);
  }

  avr_t* avr_ = nullptr;
  avr_irq_t* miso_ = nullptr;
  bool selected_ = false;
  uint8_t address_ = 0;
  bool reading_ = false;
};

// Honeywell HMC5883L, TWI slave at 0x1E. Registers 0x00..0x0C: CRA (power-on 0x10), CRB (0x20), mode
// (0x01, single measurement), data X, Z, Y (MSB first), status (LOCK bit 1, RDY bit 0), identification
// A/B/C = id. The first byte written after SLA+W sets the register pointer; each further byte written
// or read advances it, from 0x0C back to 0x00. As the datasheet says, once some but not all of the six
// data registers have been read, new data is held back (LOCK) until all six have been read or CRA or
// the mode register is written.
class Hmc5883l {
 public:
  static constexpr uint8_t kAddress = 0x1E, kDataXMsb = 0x03, kStatus = 0x09, kIdA = 0x0A, kLast = 0x0C;

  struct Write {
    uint8_t reg, value;
    avr_cycle_count_t cycle;
  };
  struct Transfer {  // from an SLA+R/W the part acknowledged to the next START or STOP
    bool read = false;
    uint8_t first_reg = 0;         // the pointer when the transfer began (write: before the pointer byte)
    std::vector<uint8_t> data;     // bytes written (the pointer first) or read
    std::vector<bool> master_ack;  // read transfers: whether the master acknowledged each byte
    uint8_t twbr = 0, twsr = 0;    // bit-rate registers at the address byte
    bool stopped = false;          // ended by a STOP (not a repeated START)
    avr_cycle_count_t cycle = 0;
  };

  std::array<uint8_t, 3> id{{'H', '4', '3'}};
  std::array<uint8_t, 13> reg{};
  std::vector<Write> writes;
  std::vector<Transfer> transfers;
  std::vector<avr_cycle_count_t> data_reads;  // cycle of each read transfer that starts in X..Y

  Hmc5883l() { power_on(); }
  Hmc5883l(const Hmc5883l&) = delete;
  Hmc5883l& operator=(const Hmc5883l&) = delete;

  bool attach(avr_t* avr) {
    avr_ = avr;
    avr_irq_t* out = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT);
    in_ = unfiltered(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT));
    if (!out || !in_) return false;
    avr_irq_register_notify(out, &Hmc5883l::on_bus, this);
    return true;
  }

  void power_on() {
    reg.fill(0);
    reg[0x00] = 0x10;
    reg[0x01] = 0x20;
    reg[0x02] = 0x01;
    for (int i = 0; i < 3; ++i) reg[kIdA + i] = id[i];
    read_mask_ = 0;
  }

  bool locked() const { return read_mask_ != 0; }

  // Sets the data registers (X, Z, Y order, big-endian) and RDY, ignoring mode and lock.
  void set_raw(int16_t x, int16_t y, int16_t z) {
    const int16_t words[3] = {x, z, y};
    for (int i = 0; i < 3; ++i) {
      reg[kDataXMsb + 2 * i] = static_cast<uint8_t>(static_cast<uint16_t>(words[i]) >> 8);
      reg[kDataXMsb + 2 * i + 1] = static_cast<uint8_t>(words[i]);
    }
    reg[kStatus] = static_cast<uint8_t>(reg[kStatus] | 0x01);
  }
  // A new measurement as the part produces one in continuous mode: only in continuous-measurement mode
  // (mode register MD = 00) and while the data registers are not locked. Returns whether it was placed.
  bool publish(int16_t x, int16_t y, int16_t z) {
    if ((reg[0x02] & 0x03) != 0 || locked()) return false;
    set_raw(x, y, z);
    return true;
  }

 private:
  void advance() { pointer_ = pointer_ >= kLast ? 0 : static_cast<uint8_t>(pointer_ + 1); }

  uint8_t read_register() {
    const uint8_t r = pointer_;
    const uint8_t v = r <= kLast ? reg[r] : 0;
    if (r >= kDataXMsb && r < kDataXMsb + 6) {
      read_mask_ = static_cast<uint8_t>(read_mask_ | (1u << (r - kDataXMsb)));
      if (read_mask_ == 0x3F) {
        read_mask_ = 0;
        reg[kStatus] = static_cast<uint8_t>(reg[kStatus] & ~0x01);  // RDY: the sample was taken
      }
      reg[kStatus] = static_cast<uint8_t>((reg[kStatus] & ~0x02) | (read_mask_ ? 0x02 : 0));
    }
    advance();
    return v;
  }

  void write_register(uint8_t value) {
    const uint8_t r = pointer_;
    writes.push_back({r, value, avr_->cycle});
    if (r <= 0x02) {  // CRA, CRB, mode are writable; the rest ignores writes
      reg[r] = value;
      if (r != 0x01) {  // a CRA or mode write releases the data lock
        read_mask_ = 0;
        reg[kStatus] = static_cast<uint8_t>(reg[kStatus] & ~0x02);
      }
    }
    advance();
  }

  void answer(uint8_t msg, uint8_t data) { avr_raise_irq(in_, avr_twi_irq_msg(msg, address_byte_, data)); }

  static void on_bus(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<Hmc5883l*>(param);
    avr_twi_msg_irq_t m;
    m.u.v = value;
    const uint8_t msg = m.u.twi.msg;
    if (msg & TWI_COND_STOP) {
      if (self->selected_ && !self->transfers.empty()) self->transfers.back().stopped = true;
      self->selected_ = false;
    }
    if (msg & TWI_COND_START) {
      self->selected_ = (m.u.twi.addr >> 1) == kAddress;
      if (self->selected_) {
        self->address_byte_ = m.u.twi.addr;
        Transfer t;
        t.read = (m.u.twi.addr & 1) != 0;
        t.first_reg = self->pointer_;
        t.twbr = self->avr_->data[kTwbr];
        t.twsr = static_cast<uint8_t>(self->avr_->data[kTwsr] & 0x03);
        t.cycle = self->avr_->cycle;
        self->transfers.push_back(t);
        self->first_write_ = true;
        self->answer(TWI_COND_ACK, 1);
      }
      return;
    }
    if (!self->selected_ || self->transfers.empty()) return;
    Transfer& t = self->transfers.back();
    if ((msg & TWI_COND_WRITE) && !t.read) {
      t.data.push_back(m.u.twi.data);
      if (self->first_write_) {
        self->first_write_ = false;
        self->pointer_ = m.u.twi.data;
        t.first_reg = self->pointer_;
      } else {
        self->write_register(m.u.twi.data);
      }
      self->answer(TWI_COND_ACK, 1);
    } else if ((msg & TWI_COND_READ) && t.read) {
      if (t.data.empty() && self->pointer_ >= kDataXMsb && self->pointer_ < kDataXMsb + 6) {
        self->data_reads.push_back(self->avr_->cycle);
      }
      const uint8_t v = self->read_register();
      t.data.push_back(v);
      t.master_ack.push_back((msg & TWI_COND_ACK) != 0);
      self->answer(TWI_COND_READ, v);
    }
  }

  avr_t* avr_ = nullptr;
  avr_irq_t* in_ = nullptr;
  bool selected_ = false;
  bool first_write_ = false;
  uint8_t address_byte_ = 0;
  uint8_t pointer_ = 0;
  uint8_t read_mask_ = 0;  // data registers read since the last complete read (bit 0 = X MSB)
};

}  // namespace parts
