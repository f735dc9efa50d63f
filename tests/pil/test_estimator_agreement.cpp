// Agreement of the estimators across builds: the recorded sensor log (replay/recorded_log.inc,
// 3 s of a PIL hover's take-off at 100 Hz) runs through the attitude observer and the position filter
// natively, on the ATmega2560 (simavr, apm25_estimator_replay) and on the Cortex-M4F (QEMU,
// mps2_estimator_replay). Same source (replay/replay_core.h), three compilers and float libraries:
// the estimates must agree within the tolerances below, and the figures are printed.
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "replay_core.h"

extern char** environ;

namespace {

const quad::replay::Row kLog[] = {
#include "recorded_log.inc"
};

using Record = std::vector<float>;  // q0..q3, p n/e/d, v n/e/d

// Parses "R k h h h ..." lines (floats as their 8-hex-digit bits) up to the closing "E".
bool parse(const std::string& text, std::vector<Record>* out, std::string* error) {
  std::istringstream in(text);
  std::string line;
  bool closed = false;
  while (std::getline(in, line)) {
    if (line == "E") {
      closed = true;
      break;
    }
    std::istringstream fields(line);
    std::string tag;
    unsigned k;
    fields >> tag >> k;
    if (tag != "R") continue;  // emulator chatter
    Record r;
    std::string hex;
    while (fields >> hex) {
      const uint32_t bits = static_cast<uint32_t>(std::stoul(hex, nullptr, 16));
      float v;
      std::memcpy(&v, &bits, sizeof v);
      r.push_back(v);
    }
    if (r.size() != 10) {
      *error = "malformed record: " + line;
      return false;
    }
    out->push_back(r);
  }
  if (!closed) *error = "no closing 'E' line (the replay did not finish)";
  return closed;
}

std::string run_host() {
  std::string text;
  quad::replay::run(
      sizeof kLog / sizeof kLog[0], [](uint16_t i, quad::replay::Row& row) { row = kLog[i]; },
      [&](char c) { text += c; });
  return text;
}

// Runs avr_pil with UART0 on a pseudo-terminal and collects what the AVR sends until "E\n".
std::string run_avr(std::string* error) {
  int master = -1, slave = -1;
  char name[256];
  if (openpty(&master, &slave, name, nullptr, nullptr) != 0) {
    *error = "openpty failed";
    return "";
  }
  termios tio;
  tcgetattr(slave, &tio);
  cfmakeraw(&tio);
  tcsetattr(slave, TCSANOW, &tio);
  const char* argv[] = {AVR_PIL_PATH, "--elf", AVR_REPLAY_ELF, "--uart0", name, nullptr};
  pid_t pid;
  if (posix_spawn(&pid, AVR_PIL_PATH, nullptr, nullptr, const_cast<char**>(argv), environ) != 0) {
    *error = "cannot start " AVR_PIL_PATH;
    return "";
  }
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (text.find("E\n") == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    pollfd p{master, POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    char buf[4096];
    const ssize_t n = read(master, buf, sizeof buf);
    if (n > 0) text.append(buf, static_cast<size_t>(n));
  }
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
  close(master);
  close(slave);
  return text;
}

std::string run_cortexm(const std::string& out_path, std::string* error) {
  std::remove(out_path.c_str());
  const std::string serial = "file:" + out_path;
  const char* argv[] = {QEMU_PATH, "-M", "mps2-an386", "-nographic", "-monitor", "none", "-semihosting-config",
                        "enable=on,target=native", "-serial", serial.c_str(), "-kernel", CORTEXM_REPLAY_ELF, nullptr};
  pid_t pid;
  if (posix_spawn(&pid, QEMU_PATH, nullptr, nullptr, const_cast<char**>(argv), environ) != 0) {
    *error = "cannot start " QEMU_PATH;
    return "";
  }
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream in(out_path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Difference {
  double attitude_rad = 0.0;  // largest rotation angle between the two attitudes
  double position_m = 0.0;
  double velocity_mps = 0.0;
};

Difference compare(const std::vector<Record>& a, const std::vector<Record>& b) {
  Difference d;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) {
    // Rotation angle of conj(qa) * qb, from its vector part and scalar part (acos of a dot product
    // near 1 would report the floats' norm error as an angle).
    const double wa = a[i][0], xa = a[i][1], ya = a[i][2], za = a[i][3];
    const double wb = b[i][0], xb = b[i][1], yb = b[i][2], zb = b[i][3];
    const double w = wa * wb + xa * xb + ya * yb + za * zb;
    const double x = wa * xb - wb * xa - (ya * zb - za * yb);
    const double y = wa * yb - wb * ya - (za * xb - xa * zb);
    const double z = wa * zb - wb * za - (xa * yb - ya * xb);
    d.attitude_rad = std::max(d.attitude_rad, 2.0 * std::atan2(std::sqrt(x * x + y * y + z * z), std::fabs(w)));
    for (int j = 4; j < 7; ++j) d.position_m = std::max(d.position_m, std::fabs(double(a[i][j]) - b[i][j]));
    for (int j = 7; j < 10; ++j) d.velocity_mps = std::max(d.velocity_mps, std::fabs(double(a[i][j]) - b[i][j]));
  }
  return d;
}

// Tolerances, about 30 to 200 times the differences measured (docs/targets.md): the AVR build came out
// bit-identical to the host's, the Cortex-M build (fused multiply-adds) 5e-8 rad, 1.2e-7 m, 3.6e-7 m/s.
// A real divergence (a different branch, a double/float mix-up, a miscompiled approximation) is orders
// of magnitude larger.
constexpr double kAttitudeTolRad = 1e-5;
constexpr double kPositionTolM = 1e-5;
constexpr double kVelocityTolMps = 1e-5;

void expect_agreement(const char* target, const std::vector<Record>& host, const std::vector<Record>& other) {
  ASSERT_EQ(other.size(), host.size()) << target;
  const Difference d = compare(host, other);
  std::printf("%s vs host over %zu records: attitude %.3g rad, position %.3g m, velocity %.3g m/s\n", target,
              host.size(), d.attitude_rad, d.position_m, d.velocity_mps);
  EXPECT_LT(d.attitude_rad, kAttitudeTolRad) << target;
  EXPECT_LT(d.position_m, kPositionTolM) << target;
  EXPECT_LT(d.velocity_mps, kVelocityTolMps) << target;
}

std::vector<Record> host_records() {
  std::vector<Record> records;
  std::string error;
  EXPECT_TRUE(parse(run_host(), &records, &error)) << error;
  return records;
}

TEST(EstimatorAgreement, ReplayMovesTheEstimates) {
  // The log is a take-off: a replay that left the estimates at rest would agree trivially.
  const std::vector<Record> host = host_records();
  ASSERT_EQ(host.size(), 60u);
  EXPECT_LT(host.back()[6], -0.5f) << "the filter did not follow the climb";
  EXPECT_GT(std::fabs(host.back()[9]), 0.1f) << "no vertical speed in the climb";
}

TEST(EstimatorAgreement, AvrMatchesHost) {
  ASSERT_EQ(access(AVR_REPLAY_ELF, R_OK), 0) << AVR_REPLAY_ELF << " is not built (make avr)";
  std::string error;
  const std::string text = run_avr(&error);
  ASSERT_TRUE(error.empty()) << error;
  std::vector<Record> avr;
  ASSERT_TRUE(parse(text, &avr, &error)) << error;
  expect_agreement("ATmega2560", host_records(), avr);
}

TEST(EstimatorAgreement, CortexMMatchesHost) {
  ASSERT_EQ(access(CORTEXM_REPLAY_ELF, R_OK), 0) << CORTEXM_REPLAY_ELF << " is not built (make cortex-m4)";
  std::string error;
  const std::string text = run_cortexm(::testing::TempDir() + "estimator_replay_cortexm.txt", &error);
  ASSERT_TRUE(error.empty()) << error;
  std::vector<Record> arm;
  ASSERT_TRUE(parse(text, &arm, &error)) << error;
  expect_agreement("Cortex-M4F", host_records(), arm);
}

}  // namespace
