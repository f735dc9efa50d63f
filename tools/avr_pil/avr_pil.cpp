// avr_pil: processor-in-the-loop host for the APM 2.5 image. Runs an AVR .elf on simavr's ATmega2560
// at 16 MHz and bridges its UART0 and UART2 to serial devices (normally the pseudo-terminals the
// simulator created), byte for byte, with flow control so no byte is dropped.
//
//   avr_pil --elf IMAGE.elf [--uart0 PATH] [--uart2 PATH] [--uart0-baud N] [--uart2-baud N]
//           [--params FILE] [--dataflash FILE] [--realtime] [--max-seconds S]
//
// The command line matches quad_firmware's, so the simulator starts either the same way
// (`quad_sim --firmware "avr_pil --elf build/avr-apm25/firmware/quad_fw.elf"`). A port given no
// path gets a new pseudo-terminal whose path is printed. The baud options are accepted for that
// compatibility: the bytes' timing on the wire is the AVR's own (simavr times its UARTs from UBRR).
// simavr's uart_pty part is not used: it drops input bytes; this bridge feeds input only while the
// UART signals XON.
//
// --params FILE (quad_sim passes the scenario's firmware parameters) is stored the way the firmware
// stores it (fw::build_param_storage, the firmware's own params_save_all) and preloaded into the
// EEPROM before the CPU starts, so the image boots with those values as quad_firmware does. Without it
// the EEPROM starts erased: defaults.
//
// The board's DataFlash (AT45DB321D on USART3, at45db321d.h) is always attached, as on the board; with
// --dataflash FILE its memory is read from FILE when it exists and written back at exit (a missing file:
// a fresh chip), so one run's logs are there for the next.
//
// It also times the firmware's own work to the cycle: the flight application marks the phases of each
// iteration on GPIOR1 (hal::TracePoint), and at exit this prints, each as median, 99th percentile,
// maximum and the iteration of the maximum: the control part (estimation, modes, control, mixing: no
// I/O) flown and on the ground, the whole iteration (all, and flown only), each vision fix, each stage
// of FlightApp::step (estimator, mode machine, control, landing and telemetry, parameter and log stream,
// the flight log, a fix step inside an iteration, a fix fused on arrival), and each period's work (the
// iteration and the fixes fused on arrival before the next one). Against the period (SYS_LOOP_HZ from --params, else its
// default, at 16 MHz) it counts the overruns of the whole iteration and of the period's work. It prints
// the five longest flown iterations stage by stage, and with --iterations-csv FILE writes every flown
// iteration's stages to FILE.
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <termios.h>
#include <unistd.h>

#include "at45db321d.h"   // the board's DataFlash
#include "param_file.h"    // fw::build_param_storage: the EEPROM image of a --params file
#include "quad/firmware/params.h"  // SYS_LOOP_HZ: the period the iterations are measured against
#include "quad/hal/hal.h"  // hal::TracePoint: the phase numbers the firmware writes to GPIOR1
#include "stack_pointer.h"  // the peak stack

#include <simavr/avr_eeprom.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <deque>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

// simavr's ELF loader allocates and never frees: under AddressSanitizer, do not report that as a leak
// of this program (the hook is only consulted by sanitizer builds).
extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }

namespace {

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

// One AVR UART bridged to one file descriptor.
struct UartBridge {
  char name = '0';
  uint16_t ucsrb = 0;  // data address of UCSRnB, whose RXEN bit says the firmware listens
  int fd = -1;
  avr_irq_t* input = nullptr;  // host -> AVR
  const avr_t* avr = nullptr;
  bool xon = true;             // the AVR's receive FIFO can take bytes
  std::deque<uint8_t> to_avr;
  std::vector<uint8_t> to_host;
  uint64_t bytes_in = 0, bytes_out = 0;

  // Bytes wait on the host side until the firmware has enabled its receiver: a pty peer may write
  // before the image has booted, and the simulated UART would drop them.
  void feed(const avr_t* avr) {
    if (!(avr->data[ucsrb] & (1u << 4))) return;  // RXENn is bit 4 of UCSRnB
    while (xon && !to_avr.empty()) {
      const uint8_t b = to_avr.front();
      to_avr.pop_front();
      ++bytes_in;
      avr_raise_irq(input, b);  // may call on_xoff re-entrantly
    }
  }
};

void on_output(avr_irq_t*, uint32_t value, void* param) {
  auto* u = static_cast<UartBridge*>(param);
  u->to_host.push_back(static_cast<uint8_t>(value));
  ++u->bytes_out;
}
void on_xon(avr_irq_t*, uint32_t, void* param) {
  auto* u = static_cast<UartBridge*>(param);
  u->xon = true;
  u->feed(u->avr);
}
void on_xoff(avr_irq_t*, uint32_t, void* param) { static_cast<UartBridge*>(param)->xon = false; }

bool make_raw(int fd) {
  termios tio{};
  if (tcgetattr(fd, &tio) != 0) return true;  // not a terminal (e.g. a pipe or socket): nothing to set
  cfmakeraw(&tio);
  return tcsetattr(fd, TCSANOW, &tio) == 0;
}

// Opens `path`, or, if empty, a new pseudo-terminal whose slave path is printed for the user.
int open_port(const std::string& path, char uart) {
  if (!path.empty()) {
    const int fd = open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) {
      std::fprintf(stderr, "avr_pil: cannot open UART%c device %s: %s\n", uart, path.c_str(), std::strerror(errno));
      return -1;
    }
    if (!make_raw(fd)) {
      std::fprintf(stderr, "avr_pil: cannot set raw mode on %s: %s\n", path.c_str(), std::strerror(errno));
      close(fd);
      return -1;
    }
    return fd;
  }
  int master = -1, slave = -1;
  char name[256];
  if (openpty(&master, &slave, name, nullptr, nullptr) != 0) {
    std::fprintf(stderr, "avr_pil: openpty for UART%c failed: %s\n", uart, std::strerror(errno));
    return -1;
  }
  make_raw(slave);
  make_raw(master);
  fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
  std::printf("avr_pil: UART%c on %s\n", uart, name);
  std::fflush(stdout);
  // The slave stays open so the master does not see hang-ups between clients.
  return master;
}

// Cycle counts of the phases the firmware marks on GPIOR1 (quad/hal/hal.h, hal::TracePoint). Every
// figure is measured on the AVR's cycle counter, so interrupts taken inside a phase count in it.
constexpr avr_io_addr_t kGpior1 = 0x4A;
// --pc-profile FILE: the cycles of every instruction executed inside the control iterations and the vision
// fixes (interrupts included) from the first flown iteration on, by program address
// (tools/avr_pil/pc_profile.py sums them by function), and in FILE.periods each period's cycles (the
// iteration's, then with the fixes fused after it, before the next one).
bool g_pc_profile_armed = false;
struct PhaseProfile {
  struct Sample {
    uint32_t cycles;
    uint32_t iteration;  // which iteration (0 the first), the simulator's step at its rate
  };
  using Samples = std::vector<Sample>;
  // The stages of FlightApp::step, each from the mark before it (hal.h), and the fix steps.
  enum Stage {
    kEstimator, kModes, kControl, kTelemetry, kStream, kFlightLog, kFixInIteration, kFixOnArrival, kStageCount
  };
  static constexpr const char* kStageNames[kStageCount] = {
      "stage estimator", "stage mode machine", "stage control", "stage landing and telemetry",
      "stage parameter and log stream", "stage flight log", "stage fix step in an iteration",
      "stage fix on arrival"};

  uint32_t period_cycles = 160000;  // SYS_LOOP_HZ at 16 MHz (set from --params)
  uint64_t step_begin = 0, fix_begin = 0, last_mark = 0;
  Sample period_work{0, 0};  // the last iteration and the fixes fused on arrival after it
  bool in_step = false, in_fix = false, period_open = false, period_flown = false;
  Samples control_flown, control_idle, step, step_flown, fix, work, work_flown;
  Samples stages[kStageCount];
  // Each flown iteration's stages, for the breakdown of the longest ones.
  struct Breakdown {
    Sample whole;
    uint32_t stage[kStageCount];
  };
  Breakdown current{};
  std::vector<Breakdown> flown_breakdowns;
  bool flown = false;  // the current iteration computed motor commands
  uint32_t iterations = 0;
  Sample sample(const avr_t* avr, uint64_t since) const {
    return {static_cast<uint32_t>(avr->cycle - since), iterations == 0 ? 0 : iterations - 1};
  }
  void stage(const avr_t* avr, Stage s) {
    if (in_step) {
      stages[s].push_back(sample(avr, last_mark));
      current.stage[s] += stages[s].back().cycles;
    }
    last_mark = avr->cycle;
  }
  // The work of one period: the iteration and the vision fixes fused on arrival before the next one (in
  // lockstep the emulated time between iterations follows the simulator, so the idle loop's wake-ups in
  // it are not the period's).
  void close_period() {
    if (!period_open) return;
    work.push_back(period_work);
    if (period_flown) work_flown.push_back(period_work);
    period_open = false;
  }

  static void on_write(avr_t* avr, avr_io_addr_t, uint8_t v, void* param) {
    auto* p = static_cast<PhaseProfile*>(param);
    const uint64_t now = avr->cycle;
    using Point = quad::hal::TracePoint;
    switch (static_cast<Point>(v)) {
      case Point::kStepBegin:
        p->close_period();
        p->step_begin = p->last_mark = now;
        p->in_step = true;
        p->flown = false;
        p->current = Breakdown{};
        ++p->iterations;
        break;
      case Point::kEstimated: p->stage(avr, kEstimator); break;
      case Point::kModesDone: p->stage(avr, kModes); break;
      case Point::kControlIdle:
        if (p->in_step) p->control_idle.push_back(p->sample(avr, p->step_begin));
        p->stage(avr, kControl);
        break;
      case Point::kControlFlown:
        if (p->in_step) p->control_flown.push_back(p->sample(avr, p->step_begin));
        p->stage(avr, kControl);
        p->flown = true;
        g_pc_profile_armed = true;
        break;
      case Point::kTelemetryDone: p->stage(avr, kTelemetry); break;
      case Point::kStreamed: p->stage(avr, kStream); break;
      case Point::kStepEnd:
        if (p->in_step) {
          p->stage(avr, kFlightLog);
          p->step.push_back(p->sample(avr, p->step_begin));
          if (p->flown) {
            p->step_flown.push_back(p->step.back());
            p->current.whole = p->step.back();
            p->flown_breakdowns.push_back(p->current);
          }
          p->period_flown = p->flown;
          p->period_work = p->step.back();
          p->period_open = true;
        }
        p->in_step = false;
        break;
      case Point::kFixBegin: p->fix_begin = now; p->in_fix = true; break;
      case Point::kFixEnd:
        if (p->in_fix) {
          p->fix.push_back(p->sample(avr, p->fix_begin));
          p->stages[p->in_step ? kFixInIteration : kFixOnArrival].push_back(p->fix.back());
          if (p->in_step) p->current.stage[kFixInIteration] += p->fix.back().cycles;
          if (!p->in_step && p->period_open) p->period_work.cycles += p->fix.back().cycles;
          // The fix's cycles are its own stage, not the next one's.
          if (p->in_step) p->last_mark = now;
        }
        p->in_fix = false;
        break;
      default: break;
    }
  }

  static void report(const char* what, Samples v) {
    if (v.empty()) return;
    std::sort(v.begin(), v.end(), [](const Sample& a, const Sample& b) { return a.cycles < b.cycles; });
    std::fprintf(stderr, "avr_pil: cycles of %s: %zu samples, median %u, p99 %u, max %u (iteration %u)\n", what,
                 v.size(), v[v.size() / 2].cycles, v[std::min(v.size() - 1, v.size() * 99 / 100)].cycles,
                 v.back().cycles, v.back().iteration);
  }
  // Every flown iteration, stage by stage, as CSV (--iterations-csv).
  void write_csv(const std::string& path) const {
    FILE* f = std::fopen(path.c_str(), "w");
    if (f == nullptr) {
      std::fprintf(stderr, "avr_pil: cannot write %s\n", path.c_str());
      return;
    }
    std::fprintf(f, "iteration,whole,estimator,modes,control,telemetry,stream,flight_log,fix_step\n");
    for (const Breakdown& b : flown_breakdowns) {
      std::fprintf(f, "%u,%u", b.whole.iteration, b.whole.cycles);
      for (int s = 0; s < kFixOnArrival; ++s) std::fprintf(f, ",%u", b.stage[s]);
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
  // The n longest flown iterations, stage by stage.
  void longest_flown(size_t n) const {
    std::vector<Breakdown> v = flown_breakdowns;
    n = std::min(n, v.size());
    std::partial_sort(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n), v.end(),
                      [](const Breakdown& a, const Breakdown& b) { return a.whole.cycles > b.whole.cycles; });
    for (size_t i = 0; i < n; ++i) {
      std::fprintf(stderr, "avr_pil: longest flown iteration %zu: %u cycles (iteration %u):", i + 1, v[i].whole.cycles,
                   v[i].whole.iteration);
      for (int s = 0; s < kFixOnArrival; ++s) std::fprintf(stderr, " %s %u;", kStageNames[s] + 6, v[i].stage[s]);
      std::fprintf(stderr, "\n");
    }
  }
  void overruns(const char* what, const Samples& v) const {
    if (v.empty()) return;
    const size_t over = static_cast<size_t>(std::count_if(v.begin(), v.end(), [&](const Sample& s) { return s.cycles > period_cycles; }));
    std::fprintf(stderr, "avr_pil: overruns of %s: %zu of %zu (%.2f %%) over the %u-cycle period\n", what, over,
                 v.size(), 100.0 * static_cast<double>(over) / static_cast<double>(v.size()), period_cycles);
  }
  void report() const {
    report("control flown", control_flown);
    report("control on the ground", control_idle);
    report("whole iteration", step);
    report("whole iteration flown", step_flown);
    report("vision fix", fix);
    report("iteration and fixes after it", work);
    report("iteration and fixes after it flown", work_flown);
    for (int s = 0; s < kStageCount; ++s) report(kStageNames[s], stages[s]);
    longest_flown(5);
    overruns("whole iteration", step);
    overruns("whole iteration flown", step_flown);
    overruns("iteration and fixes after it", work);
    overruns("iteration and fixes after it flown", work_flown);
  }
};
constexpr const char* PhaseProfile::kStageNames[];

// The control period in cycles at 16 MHz: SYS_LOOP_HZ from the --params file, else its default.
bool period_cycles(const std::string& params, uint32_t* cycles, std::string* error) {
  float hz = quad::fw::param_info(quad::fw::kLoopHz).default_value;
  if (!params.empty()) {
    std::vector<quad::fw::ParamOverride> values;
    if (!quad::fw::read_param_file(params, &values, error)) return false;
    for (const quad::fw::ParamOverride& o : values) {
      if (o.index == quad::fw::kLoopHz) hz = o.value;
    }
  }
  *cycles = static_cast<uint32_t>(16e6 / static_cast<double>(hz) + 0.5);
  return true;
}

void attach(avr_t* avr, UartBridge& u) {
  u.avr = avr;
  uint32_t flags = 0;  // no console printing, no polling sleep (it would usleep inside the AVR loop)
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS(u.name), &flags);
  u.input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(u.name), UART_IRQ_INPUT);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(u.name), UART_IRQ_OUTPUT), on_output, &u);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(u.name), UART_IRQ_OUT_XON), on_xon, &u);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(u.name), UART_IRQ_OUT_XOFF), on_xoff, &u);
}

// Moves bytes between the host side and the bridge's queues. Returns false when the peer hung up.
bool pump(UartBridge& u) {
  if (u.fd < 0) return true;
  uint8_t buf[4096];
  for (;;) {
    const ssize_t n = read(u.fd, buf, sizeof buf);
    if (n > 0) {
      u.to_avr.insert(u.to_avr.end(), buf, buf + n);
      continue;
    }
    if (n == 0) return true;  // EOF on a pty master only means no client yet
    if (errno == EAGAIN || errno == EINTR) break;
    if (errno == EIO) break;  // pty slave closed for the moment
    std::fprintf(stderr, "avr_pil: UART%c read failed: %s\n", u.name, std::strerror(errno));
    return false;
  }
  size_t off = 0;
  while (off < u.to_host.size()) {
    const ssize_t n = write(u.fd, u.to_host.data() + off, u.to_host.size() - off);
    if (n > 0) {
      off += static_cast<size_t>(n);
    } else if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
      pollfd p{u.fd, POLLOUT, 0};
      poll(&p, 1, 5);
      if (g_stop) break;
    } else {
      std::fprintf(stderr, "avr_pil: UART%c write failed: %s\n", u.name, std::strerror(errno));
      return false;
    }
  }
  u.to_host.clear();
  u.feed(u.avr);
  return true;
}

int usage() {
  std::fprintf(stderr,
               "usage: avr_pil --elf IMAGE.elf [--uart0 PATH] [--uart2 PATH] [--uart0-baud N] [--uart2-baud N]\n"
               "               [--params FILE] [--dataflash FILE] [--iterations-csv FILE] [--pc-profile FILE] [--realtime] [--max-seconds S]\n");
  return 2;
}

// Copies `blob` to the start of the EEPROM: hal/avr/storage.cpp maps storage offset N to EEPROM
// address N (eeprom_read_block), and the blob already holds the store at the firmware's own offset.
// simavr's ioctl returns -1 even when it copied, so the copy is read back to be sure.
bool preload_eeprom(avr_t* avr, std::vector<uint8_t>& blob) {  // non-const: simavr takes a uint8_t*
  avr_eeprom_desc_t set{blob.data(), 0, static_cast<uint32_t>(blob.size())};
  if (avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &set) == -2) return false;
  std::vector<uint8_t> back(blob.size(), 0);
  avr_eeprom_desc_t get{back.data(), 0, static_cast<uint32_t>(back.size())};
  if (avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &get) == -2) return false;
  return back == blob;
}

}  // namespace

int main(int argc, char** argv) {
  std::string elf, uart0, uart2, params, dataflash, iterations_csv, pc_profile;
  bool realtime = false;
  double max_seconds = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* what) -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "avr_pil: %s needs a value\n", what);
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--elf") elf = value("--elf");
    else if (a == "--uart0") uart0 = value("--uart0");
    else if (a == "--uart2") uart2 = value("--uart2");
    else if (a == "--uart0-baud" || a == "--uart2-baud") value(a.c_str());
    else if (a == "--params") params = value("--params");
    else if (a == "--dataflash") dataflash = value("--dataflash");
    else if (a == "--iterations-csv") iterations_csv = value("--iterations-csv");
    else if (a == "--pc-profile") pc_profile = value("--pc-profile");
    else if (a == "--realtime") realtime = true;
    else if (a == "--max-seconds") max_seconds = std::atof(value("--max-seconds"));
    else {
      std::fprintf(stderr, "avr_pil: unknown option %s\n", a.c_str());
      return usage();
    }
  }
  if (elf.empty()) return usage();

  avr_t* avr = avr_make_mcu_by_name("atmega2560");
  if (!avr) {
    std::fprintf(stderr, "avr_pil: simavr has no atmega2560 core\n");
    return 1;
  }
  avr_init(avr);
  avr->frequency = 16000000;
  // A bad parameter file stops here, before anything runs: the firmware would silently fly defaults.
  std::vector<uint8_t> eeprom;
  if (!params.empty()) {
    std::string error;
    if (!quad::fw::build_param_storage(params, avr->e2end + 1u, &eeprom, &error)) {
      std::fprintf(stderr, "avr_pil: --params: %s\n", error.c_str());
      return 1;
    }
  }
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf.c_str(), &fw) != 0) {
    std::fprintf(stderr, "avr_pil: %s: cannot read the ELF image\n", elf.c_str());
    return 1;
  }
  // simavr's default sleep handler usleep()s for the time the AVR sleeps: the firmware's idle() would
  // pace the bridge to the wall clock. Sleep costs nothing here; --realtime paces below.
  avr->sleep = [](avr_t*, avr_cycle_count_t) {};
  avr_load_firmware(avr, &fw);
  // After the ELF's own .eeprom section (if any), which avr_load_firmware copies in.
  if (!eeprom.empty() && !preload_eeprom(avr, eeprom)) {
    std::fprintf(stderr, "avr_pil: cannot preload %zu bytes of %s into the simulated EEPROM\n", eeprom.size(),
                 params.c_str());
    return 1;
  }

  UartBridge u0, u2;
  u0.name = '0';
  u0.ucsrb = 0xC1;  // ATmega2560 UCSR0B
  u2.name = '2';
  u2.ucsrb = 0xD1;  // ATmega2560 UCSR2B
  u0.fd = open_port(uart0, '0');
  u2.fd = open_port(uart2, '2');
  if (u0.fd < 0 || u2.fd < 0) return 1;
  attach(avr, u0);
  attach(avr, u2);
  // The board's DataFlash, always there (the images probe it); its memory from and back to --dataflash.
  parts::At45db321d flash;
  if (!flash.attach(avr)) {
    std::fprintf(stderr, "avr_pil: cannot attach the emulated DataFlash to USART3\n");
    return 1;
  }
  if (!dataflash.empty() && !flash.load(dataflash) && std::ifstream(dataflash).good()) {
    std::fprintf(stderr, "avr_pil: --dataflash %s: not a %u-byte AT45DB321D image\n", dataflash.c_str(),
                 parts::At45db321d::kPages * parts::At45db321d::kPageSize);
    return 1;
  }

  PhaseProfile profile;
  {
    std::string error;
    if (!period_cycles(params, &profile.period_cycles, &error)) {
      std::fprintf(stderr, "avr_pil: --params: %s\n", error.c_str());
      return 1;
    }
  }
  avr_register_io_write(avr, kGpior1, &PhaseProfile::on_write, &profile);

  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  signal(SIGPIPE, SIG_IGN);

  const auto t0 = std::chrono::steady_clock::now();
  constexpr int kSlice = 2000;  // AVR instructions between host-side polls (~0.1-0.3 ms of AVR time)
  int state = cpu_Running;
  std::vector<uint64_t> pc_cycles(pc_profile.empty() ? 0 : 0x20000, 0);
  std::vector<uint64_t> periods;
  uint64_t period_acc = 0, step_acc = 0;
  std::vector<uint64_t> period_steps;
  bool was_in_step = false;
  uint16_t lowest_sp = static_cast<uint16_t>(avr->ramend);
  while (!g_stop) {
    for (int i = 0; i < kSlice; ++i) {
      const uint32_t pc_before = avr->pc;
      const uint64_t cycle_before = avr->cycle;
      const bool running = avr->state == cpu_Running;
      state = avr_run(avr);
      if (!pc_profile.empty() && running && g_pc_profile_armed && (profile.in_step || profile.in_fix)) {
        pc_cycles[pc_before >> 1] += avr->cycle - cycle_before;
        // A period's work: an iteration and the fixes fused after it, up to the next iteration.
        if (profile.in_step && !was_in_step && period_acc != 0) {
          periods.push_back(period_acc);
          period_steps.push_back(step_acc);
          period_acc = step_acc = 0;
        }
        period_acc += avr->cycle - cycle_before;
        if (profile.in_step) step_acc += avr->cycle - cycle_before;
      }
      was_in_step = profile.in_step;
      // Peak stack: the lowest stack pointer seen at any instruction boundary.
      parts::track_lowest_stack_pointer(avr, lowest_sp);
      if (state == cpu_Done || state == cpu_Crashed || state == cpu_Sleeping) break;  // sleeping: feed it
    }
    if (state == cpu_Done || state == cpu_Crashed) break;
    if (!pump(u0) || !pump(u2)) break;
    const double avr_seconds = static_cast<double>(avr->cycle) / avr->frequency;
    if (max_seconds > 0.0 && avr_seconds >= max_seconds) break;
    if (realtime) {
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (avr_seconds > wall + 0.001) std::this_thread::sleep_for(std::chrono::duration<double>(avr_seconds - wall));
    }
  }
  pump(u0);
  pump(u2);
  if (state == cpu_Crashed) {
    std::fprintf(stderr, "avr_pil: the AVR crashed at pc 0x%05x after %llu cycles\n", avr->pc,
                 static_cast<unsigned long long>(avr->cycle));
    return 1;
  }
  std::fprintf(stderr, "avr_pil: stopped after %.3f s of AVR time; UART0 %llu in / %llu out, UART2 %llu in / %llu out\n",
               static_cast<double>(avr->cycle) / avr->frequency, static_cast<unsigned long long>(u0.bytes_in),
               static_cast<unsigned long long>(u0.bytes_out), static_cast<unsigned long long>(u2.bytes_in),
               static_cast<unsigned long long>(u2.bytes_out));
  std::fprintf(stderr, "avr_pil: peak stack %u bytes\n", static_cast<unsigned>(avr->ramend - lowest_sp));
  if (flash.errors() > 0) std::fprintf(stderr, "avr_pil: the DataFlash refused %llu commands\n", static_cast<unsigned long long>(flash.errors()));
  if (!dataflash.empty() && !flash.save(dataflash)) {
    std::fprintf(stderr, "avr_pil: --dataflash %s: cannot write the DataFlash image\n", dataflash.c_str());
    return 1;
  }
  profile.report();
  if (!pc_profile.empty()) {
    FILE* f = std::fopen(pc_profile.c_str(), "w");
    if (f == nullptr) {
      std::fprintf(stderr, "avr_pil: --pc-profile %s: cannot write\n", pc_profile.c_str());
      return 1;
    }
    for (size_t i = 0; i < pc_cycles.size(); ++i) {
      if (pc_cycles[i] != 0) std::fprintf(f, "%zx %llu\n", i * 2, static_cast<unsigned long long>(pc_cycles[i]));
    }
    std::fclose(f);
    if (FILE* g = std::fopen((pc_profile + ".periods").c_str(), "w")) {
      for (size_t i = 0; i < periods.size(); ++i) {
        std::fprintf(g, "%llu %llu\n", static_cast<unsigned long long>(period_steps[i]),
                     static_cast<unsigned long long>(periods[i]));
      }
      std::fclose(g);
    }
    std::sort(periods.begin(), periods.end());
    if (!periods.empty()) {
      std::fprintf(stderr, "avr_pil: pc profile: %zu periods (iteration and fixes after it, from the first flown), "
                   "median %llu, p99 %llu, max %llu cycles\n", periods.size(),
                   static_cast<unsigned long long>(periods[periods.size() / 2]),
                   static_cast<unsigned long long>(periods[periods.size() * 99 / 100]),
                   static_cast<unsigned long long>(periods.back()));
    }
  }
  if (!iterations_csv.empty()) profile.write_csv(iterations_csv);
  avr_terminate(avr);
  return 0;
}
