// RAM of the flashed APM 2.5 image (apm25_board.elf) with its stack, measured by stack painting on
// simavr: every byte of SRAM is painted before the CPU starts, the image runs its real board loop with
// the board's drivers against the emulated parts (emulated_parts.h: the MPU-6000 on SPI at 1 kHz, the
// HMC5883L on TWI at 75 Hz, a PPM receiver on ICP5) and a ground station and a vision station on its
// UARTs (calibration, arming, AUTO with 30 Hz vision fixes, a parameter list and a parameter set in
// flight), and the deepest byte no longer holding the paint is the stack written. The test fails when data +
// bss + that peak exceed RAM_BUDGET bytes, or when the flight did not reach the paths it claims.
// The lowest stack pointer seen at any instruction boundary is kept too, as an independent check of the
// painting: nothing may be written below it, and a frame reserved but written only in part shows in it
// and not in the paint, so the budget counts the deeper of the two.
#include <simavr/avr_timer.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <deque>
#include <string>
#include <vector>

#include "at45db321d.h"
#include "emulated_parts.h"
#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "stack_pointer.h"

extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }  // simavr's loader leaks

namespace {

namespace mav = quad::mavlink;
constexpr avr_cycle_count_t kCyclesPerUs = 16;
constexpr uint16_t kRamStart = 0x200;  // ATmega2560 internal SRAM
constexpr uint8_t kPaint = 0xA5;

// The address of an ELF symbol in the data space (avr-nm prints it with the 0x800000 offset).
long symbol_address(const std::string& elf, const std::string& name) {
  const std::string command = "avr-nm " + elf;
  FILE* p = popen(command.c_str(), "r");
  if (p == nullptr) return -1;
  char line[256];
  long address = -1;
  while (std::fgets(line, sizeof line, p) != nullptr) {
    char sym[200];
    unsigned long value = 0;
    char type = 0;
    if (std::sscanf(line, "%lx %c %199s", &value, &type, sym) == 3 && name == sym) address = static_cast<long>(value & 0xFFFF);
  }
  pclose(p);
  return address;
}

// The flash byte address of the first text symbol whose (mangled) name contains `part`, or -1.
long code_address(const std::string& elf, const std::string& part) {
  const std::string command = "avr-nm " + elf;
  FILE* p = popen(command.c_str(), "r");
  if (p == nullptr) return -1;
  char line[256];
  long address = -1;
  while (address < 0 && std::fgets(line, sizeof line, p) != nullptr) {
    char sym[200];
    unsigned long value = 0;
    char type = 0;
    if (std::sscanf(line, "%lx %c %199s", &value, &type, sym) == 3 && (type == 't' || type == 'T') &&
        std::strstr(sym, part.c_str()) != nullptr)
      address = static_cast<long>(value);
  }
  pclose(p);
  return address;
}

// A byte stream into one of the AVR's UARTs, fed only while its receive FIFO signals XON.
struct UartIn {
  avr_irq_t* input = nullptr;
  bool xon = true;
  std::deque<uint8_t> bytes;
  void attach(avr_t* avr, char name) {
    input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(name), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(name), UART_IRQ_OUT_XON),
                            [](avr_irq_t*, uint32_t, void* self) { static_cast<UartIn*>(self)->xon = true; }, this);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(name), UART_IRQ_OUT_XOFF),
                            [](avr_irq_t*, uint32_t, void* self) { static_cast<UartIn*>(self)->xon = false; }, this);
  }
  void pump() {
    while (xon && !bytes.empty()) {
      avr_raise_irq(input, bytes.front());
      bytes.pop_front();
    }
  }
};

struct Board {
  avr_t* avr = nullptr;
  parts::Simavr16TwiFix twi_fix;
  parts::Mpu6000 mpu;
  parts::Hmc5883l hmc;
  parts::At45db321d flash;  // the board's DataFlash, which the image's log store starts
  avr_irq_t* icp = nullptr;
  UartIn uart0, uart2;
  mav::Parser from_uart0;
  mav::Sender gcs{255, 190};
  mav::Sender vision{1, 197};
  uint16_t lowest_sp = 0xFFFF;
  bool star_next = false;  // the next vision fix is a LANDING_TARGET
  long star_correction_pc = -1;  // the observer's star-attitude correction, entered this often
  int star_corrections = 0;
  // What the vehicle said on UART0.
  bool armed_seen = false, auto_seen = false;
  int param_values = 0;
  std::vector<std::string> texts;
  std::vector<mav::CommandAck> acks;
  // PPM: the index of the next edge in the repeating frame (sync gap, then eight channels).
  size_t ppm_edge = 0;

  bool load() {
    avr = parts::load_atmega2560(BOARD_ELF);
    if (!avr) return false;
    // The paint: all of SRAM, before the first instruction (the start-up code then writes data and bss).
    for (uint32_t a = kRamStart; a <= avr->ramend; ++a) avr->data[a] = kPaint;
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('2'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), &Board::on_uart0, this);
    uart0.attach(avr, '0');
    uart2.attach(avr, '2');
    icp = avr_io_getirq(avr, AVR_IOCTL_TIMER_GETIRQ('5'), TIMER_IRQ_IN_ICP);
    return icp != nullptr && twi_fix.attach(avr) && mpu.attach(avr) && hmc.attach(avr) && flash.attach(avr);
  }

  // The sensors of a level vehicle at rest, heading north, as the parts produce them: the MPU-6000 at
  // its 1 kHz sample rate (+1 g on the sensor's z axis, which points up), the HMC5883L at 75 Hz (0.21 G
  // north, 0.43 G down at 1090 LSB/G), and the PPM receiver's frames (22.5 ms, all sticks centred but
  // the throttle, low).
  void start_sources() {
    avr_cycle_timer_register(avr, 1000 * kCyclesPerUs, &Board::imu_sample, this);
    avr_cycle_timer_register(avr, 13333 * kCyclesPerUs, &Board::mag_sample, this);
    avr_cycle_timer_register(avr, 1000 * kCyclesPerUs, &Board::ppm, this);
  }
  static avr_cycle_count_t imu_sample(avr_t*, avr_cycle_count_t when, void* self) {
    static_cast<Board*>(self)->mpu.publish({{0, 0, 4096}, 0, {0, 0, 0}});
    return when + 1000 * kCyclesPerUs;
  }
  static avr_cycle_count_t mag_sample(avr_t*, avr_cycle_count_t when, void* self) {
    static_cast<Board*>(self)->hmc.publish(229, 0, 469);
    return when + 13333 * kCyclesPerUs;
  }
  static avr_cycle_count_t ppm(avr_t*, avr_cycle_count_t when, void* param) {
    auto* b = static_cast<Board*>(param);
    static const uint16_t kGapsUs[9] = {6000, 1500, 1500, 1000, 1500, 1000, 1000, 1500, 1500};
    avr_raise_irq(b->icp, 0);
    avr_raise_irq(b->icp, 1);
    b->ppm_edge = (b->ppm_edge + 1) % 9;
    return when + kGapsUs[b->ppm_edge] * kCyclesPerUs;
  }

  static void on_uart0(avr_irq_t*, uint32_t value, void* param) {
    auto* b = static_cast<Board*>(param);
    const uint8_t byte = static_cast<uint8_t>(value);
    b->from_uart0.feed(&byte, 1, [b](const mav::Frame& f) {
      mav::Heartbeat hb;
      mav::ParamValue pv;
      mav::Statustext st;
      mav::CommandAck ack;
      if (mav::decode(f, hb)) {
        b->armed_seen = b->armed_seen || (hb.base_mode & mav::kModeFlagSafetyArmed) != 0;
        b->auto_seen = b->auto_seen || hb.custom_mode == static_cast<uint32_t>(mav::FlightMode::kAuto);
      }
      if (mav::decode(f, pv)) ++b->param_values;
      if (mav::decode(f, st)) b->texts.emplace_back(st.text, strnlen(st.text, sizeof st.text));
      if (mav::decode(f, ack)) b->acks.push_back(ack);
    });
  }

  template <class Msg>
  void send(UartIn& port, mav::Sender& from, const Msg& msg) {
    uint8_t buf[mav::max_frame_length<Msg>()];
    const size_t n = from.encode(msg, buf, sizeof buf);
    port.bytes.insert(port.bytes.end(), buf, buf + n);
  }
  void command(uint16_t cmd, float p1, float p2 = 0.0f) {
    mav::CommandLong c;
    c.command = cmd;
    c.param1 = p1;
    c.param2 = p2;
    c.target_system = 1;
    c.target_component = 1;
    send(uart0, gcs, c);
  }
  uint32_t now_us() const { return static_cast<uint32_t>(avr->cycle / kCyclesPerUs); }

  // Runs to `until_us` of AVR time; vision fixes (20 ms old, at the origin 1.5 m up) every 33 ms from
  // `fixes_from_us` on, in turn an external pose and the star seen below with its attitude (0.6 deg of
  // roll: the thesis pair's star-attitude correction, EST_STAR_ATT, on the stack too).
  void run_to(uint32_t until_us, uint32_t fixes_from_us, uint32_t* next_fix_us) {
    while (now_us() < until_us) {
      for (int i = 0; i < 1000; ++i) {
        const int state = avr_run(avr);
        ASSERT_NE(state, cpu_Crashed) << "at pc 0x" << std::hex << avr->pc;
        parts::track_lowest_stack_pointer(avr, lowest_sp);
        if (static_cast<long>(avr->pc) == star_correction_pc) ++star_corrections;
      }
      if (now_us() >= fixes_from_us && now_us() >= *next_fix_us) {
        if (star_next) {
          mav::LandingTarget t;
          t.time_usec = now_us() - 20000u;
          t.frame = mav::kFrameBodyFrd;
          t.position_valid = 1;
          t.z = 1.5f;
          t.q[0] = 0.99998629f;  // q_BS = q_IB*, q_IB 0.6 deg about x
          t.q[1] = -0.00523596f;
          send(uart2, vision, t);
        } else {
          mav::VisionPositionEstimate v;
          v.usec = now_us() - 20000u;
          v.z = -1.5f;
          send(uart2, vision, v);
        }
        star_next = !star_next;
        *next_fix_us = now_us() + 33333u;
      }
      uart0.pump();
      uart2.pump();
    }
  }
};

TEST(Apm25BoardRam, DataBssAndPaintedPeakStackWithinTheBudget) {
  Board b;
  ASSERT_TRUE(b.load()) << "cannot load " << BOARD_ELF << " (make avr) or attach the emulated parts";
  const long bss_end = symbol_address(BOARD_ELF, "__bss_end");
  ASSERT_GT(bss_end, kRamStart) << "no __bss_end in " << BOARD_ELF << " (avr-nm)";
  b.start_sources();
  b.star_correction_pc = code_address(BOARD_ELF, "ConditionedObserver16correct_attitude");
  ASSERT_GT(b.star_correction_pc, 0) << "no ConditionedObserver::correct_attitude in " << BOARD_ELF << " (avr-nm)";

  uint32_t next_fix_us = 0;
  const uint32_t kFixesFrom = 2500000, kNoFixes = 0xFFFFFFFFu;
  ASSERT_NO_FATAL_FAILURE(b.run_to(3000000, kNoFixes, &next_fix_us));  // boot and the 2 s still calibration
  b.command(mav::kCmdComponentArmDisarm, 1.0f);
  ASSERT_NO_FATAL_FAILURE(b.run_to(3500000, kFixesFrom, &next_fix_us));
  b.command(mav::kCmdDoSetMode, 1.0f, static_cast<float>(mav::FlightMode::kAuto));
  ASSERT_NO_FATAL_FAILURE(b.run_to(4000000, kFixesFrom, &next_fix_us));
  mav::SetPositionTargetLocalNed sp;
  sp.target_system = 1;
  sp.coordinate_frame = mav::kFrameLocalNed;
  sp.type_mask = 0x38 | 0x1C0 | 0x800 | 0x400;  // position only
  sp.z = -2.5f;
  b.send(b.uart0, b.gcs, sp);
  mav::ParamRequestList list;
  list.target_system = 1;
  b.send(b.uart0, b.gcs, list);
  ASSERT_NO_FATAL_FAILURE(b.run_to(6000000, kFixesFrom, &next_fix_us));
  mav::ParamSet set;
  set.target_system = 1;
  std::strncpy(set.param_id, "TEL_SYS_HZ", sizeof set.param_id);
  set.param_value = 2.0f;
  b.send(b.uart0, b.gcs, set);
  ASSERT_NO_FATAL_FAILURE(b.run_to(7000000, kFixesFrom, &next_fix_us));

  std::string said;
  for (const std::string& t : b.texts) said += "\n  " + t;
  // The paths the figure claims to cover.
  EXPECT_EQ(b.mpu.reg[parts::Mpu6000::kIntEnable] & 0x01, 0x01) << "the MPU-6000 was not configured";
  EXPECT_TRUE(b.armed_seen) << "never armed; the vehicle said:" << said;
  EXPECT_TRUE(b.auto_seen) << "never in AUTO (vision fixes fused); the vehicle said:" << said;
  EXPECT_GE(b.param_values, 60) << "no parameter list in flight";
  EXPECT_GT(b.star_corrections, 10) << "the star's attitude never reached the observer";

  // The deepest byte that lost its paint, from the end of bss up.
  uint32_t lowest_touched = b.avr->ramend + 1;
  for (uint32_t a = static_cast<uint32_t>(bss_end); a <= b.avr->ramend; ++a) {
    if (b.avr->data[a] != kPaint) {
      lowest_touched = a;
      break;
    }
  }
  const long data_bss = bss_end - kRamStart;
  const long painted_stack = static_cast<long>(b.avr->ramend + 1 - lowest_touched);
  const long sp_stack = static_cast<long>(b.avr->ramend - b.lowest_sp);
  // A frame reserved but not all written (a buffer used in part) keeps its paint: the stack pointer's
  // depth is then the larger, and the one the budget counts.
  const long peak_stack = painted_stack > sp_stack ? painted_stack : sp_stack;
  const long total = data_bss + peak_stack;
  std::printf("apm25_board.elf: data + bss %ld + peak stack %ld = %ld bytes (budget %d); stack written (paint "
              "lost) %ld bytes deep, stack pointer %ld bytes deep; star-attitude corrections %d\n",
              data_bss, peak_stack, total, RAM_BUDGET, painted_stack, sp_stack, b.star_corrections);
  EXPECT_GT(lowest_touched, static_cast<uint32_t>(bss_end)) << "the stack reached bss: no paint left above it";
  EXPECT_GT(painted_stack, 256) << "the paint hardly changed: was it there when the image ran?";
  EXPECT_LE(painted_stack, sp_stack + 32) << "bytes written far below the deepest stack pointer";
  EXPECT_LE(total, RAM_BUDGET) << "data + bss + peak stack over the budget";
}

}  // namespace
