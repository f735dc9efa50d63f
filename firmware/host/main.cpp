// quad_firmware: the flight application on the host, flying the simulator in hardware-in-the-loop.
//
//   quad_firmware --uart0 PATH [--uart0-baud N] [--uart2 PATH] [--uart2-baud N] [--params FILE]
//                 [--storage FILE] [--log-dir DIR]
//
// UART0 carries HIL_SENSOR in and HIL_ACTUATOR_CONTROLS out (docs/hil-protocol.md); UART2 is the radio
// link. --params sets parameters for this run (firmware/host/param_file.h); --storage keeps the
// parameter store (what PARAM_SET writes) in a file, like the board's EEPROM. The program ends when
// the peer of UART0 hangs up, or on SIGINT / SIGTERM. --log-dir keeps the flight logs (ULog) as
// DIR/log_NNN.ulg (docs/logging.md); without it the firmware has no log store.
#include <signal.h>
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "log_dir.h"
#include "param_file.h"
#include "quad/firmware/runner.h"
#include "quad/hal/host.h"

namespace {

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

const char kUsage[] =
    "usage: quad_firmware --uart0 PATH [--uart0-baud N] [--uart2 PATH] [--uart2-baud N]\n"
    "                     [--params FILE] [--storage FILE] [--log-dir DIR]\n"
    "  --uart0 PATH       serial device of UART0 (HIL sensors in, actuators out); required\n"
    "  --uart0-baud N     its baud rate (default 921600)\n"
    "  --uart2 PATH       serial device of UART2 (radio: vision fixes, telemetry)\n"
    "  --uart2-baud N     its baud rate (default 57600)\n"
    "  --params FILE      parameter values for this run, one 'NAME VALUE' per line\n"
    "  --storage FILE     file that keeps the parameter store (default: memory only)\n"
    "  --log-dir DIR      directory of the flight logs, DIR/log_NNN.ulg (default: no logs)\n";

// The iteration clock of the host firmware: this thread's CPU time, so the loop's load, its overruns and
// its longest iteration measure the firmware's own work and not the preemption of a loaded machine
// (whose STATUSTEXT would change the radio's traffic, and the flight, from one run to the next).
uint32_t cpu_micros() {
  timespec now;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<uint32_t>(static_cast<uint64_t>(now.tv_sec) * 1000000u + static_cast<uint64_t>(now.tv_nsec) / 1000u);
}

// The vehicle's STATUSTEXT lines, also on stderr (the simulator keeps them in firmware.log).
void console(uint8_t severity, const char* text, uint8_t length) {
  std::fprintf(stderr, "quad_firmware: [%u] %.*s\n", severity, static_cast<int>(length), text);
}

bool parse_baud(const std::string& flag, const char* text, uint32_t* out, std::string* error) {
  char* end = nullptr;
  const unsigned long v = std::strtoul(text, &end, 10);
  if (end == text || *end != '\0' || !quad::hal::host::baud_supported(static_cast<uint32_t>(v))) {
    *error = flag + ": '" + text + "' is not a supported baud rate (e.g. 57600, 115200, 921600)";
    return false;
  }
  *out = static_cast<uint32_t>(v);
  return true;
}

struct Options {
  quad::hal::host::Config hal;
  std::string params_path;
  std::string log_dir;
};

bool parse_args(int argc, char** argv, Options* o, std::string* error) {
  o->hal.ports[quad::hal::kUart0].baud = 921600;
  o->hal.ports[quad::hal::kUart2].baud = 57600;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (i + 1 >= argc) {
      *error = flag + ": missing value";
      return false;
    }
    const char* value = argv[++i];
    if (flag == "--uart0") o->hal.ports[quad::hal::kUart0].path = value;
    else if (flag == "--uart2") o->hal.ports[quad::hal::kUart2].path = value;
    else if (flag == "--uart0-baud") { if (!parse_baud(flag, value, &o->hal.ports[quad::hal::kUart0].baud, error)) return false; }
    else if (flag == "--uart2-baud") { if (!parse_baud(flag, value, &o->hal.ports[quad::hal::kUart2].baud, error)) return false; }
    else if (flag == "--params") o->params_path = value;
    else if (flag == "--storage") o->hal.storage_path = value;
    else if (flag == "--log-dir") o->log_dir = value;
    else {
      *error = "unknown option '" + flag + "'";
      return false;
    }
  }
  if (o->hal.ports[quad::hal::kUart0].path.empty()) {
    *error = "--uart0 is required (the simulator's HIL port)";
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  std::string error;
  if (!parse_args(argc, argv, &options, &error)) {
    std::fprintf(stderr, "quad_firmware: %s\n%s", error.c_str(), kUsage);
    return 2;
  }
  // Check the parameter file completely before touching any device.
  std::vector<quad::fw::ParamOverride> overrides;
  if (!options.params_path.empty() && !quad::fw::read_param_file(options.params_path, &overrides, &error)) {
    std::fprintf(stderr, "quad_firmware: %s\n", error.c_str());
    return 1;
  }
  static quad::fw::LogDirectory logs;
  if (!options.log_dir.empty() && !logs.attach(options.log_dir, &error)) {
    std::fprintf(stderr, "quad_firmware: %s\n", error.c_str());
    return 1;
  }
  if (!quad::hal::host::open(options.hal, &error)) {
    std::fprintf(stderr, "quad_firmware: %s\n", error.c_str());
    return 1;
  }
  quad::hal::init();
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  signal(SIGPIPE, SIG_IGN);

  static quad::fw::FlightApp app;  // large: keep it off the stack
  quad::fw::AppIo io = quad::fw::hal_app_io();
  io.console = console;
  io.micros = cpu_micros;
  if (!options.log_dir.empty()) io.log_store = logs.store();
  quad::fw::init_hil(app, io);
  for (const quad::fw::ParamOverride& o : overrides) {
    if (const char* why = app.override_param(o.index, o.value)) {
      std::fprintf(stderr, "quad_firmware: %s: %s: %s\n", options.params_path.c_str(),
                   quad::fw::param_info(o.index).name, why);
      quad::hal::host::close();
      return 1;
    }
  }

  // run_hil() without the "forever": the host stops on a signal or when the simulator hangs up.
  while (!g_stop && !quad::hal::host::port_hung_up(quad::hal::kUart0)) {
    quad::hal::idle(20000);
    quad::fw::poll_ports(app);
    quad::hal::led_write(app.led(quad::hal::micros()));
  }
  app.close_log();
  // The loop's own timing (LoopTimer, on the thread's CPU time), for the flight report.
  const quad::fw::LoopTimer& loop = app.loop_timer();
  std::fprintf(stderr, "quad_firmware: loop: %u iterations, %u overruns, longest %u us of a %u us period\n",
               static_cast<unsigned>(loop.iterations()), static_cast<unsigned>(loop.overruns()),
               static_cast<unsigned>(loop.max_exec_us()), static_cast<unsigned>(loop.period_us()));
  quad::hal::host::close();
  return 0;
}
