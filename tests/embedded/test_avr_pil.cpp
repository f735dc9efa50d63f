// avr_pil bridges the simulated ATmega2560's UART0 and UART2 to pseudo-terminals without losing,
// reordering or corrupting a byte, in both directions, on both ports at once (the AVR echoes).
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "raw_pty.h"

#include <chrono>
#include <random>
#include <string>
#include <vector>

namespace {

// Writes `out` to fd while collecting what comes back, until all is back or the deadline passes.
std::vector<uint8_t> exchange(int fd0, const std::vector<uint8_t>& out0, int fd2, const std::vector<uint8_t>& out2,
                              std::vector<uint8_t>& in2, double timeout_s) {
  std::vector<uint8_t> in0;
  size_t sent0 = 0, sent2 = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while ((in0.size() < out0.size() || in2.size() < out2.size()) && std::chrono::steady_clock::now() < deadline) {
    // Send in bursts of at most 64 bytes with at most 128 bytes unanswered, like a MAVLink peer that
    // sends a frame and waits for the reply: the echo image's ring holds 256 bytes.
    if (sent0 < out0.size() && sent0 - in0.size() < 128)
      sent0 += std::max<ssize_t>(0, write(fd0, out0.data() + sent0, std::min<size_t>(64, out0.size() - sent0)));
    if (sent2 < out2.size() && sent2 - in2.size() < 128)
      sent2 += std::max<ssize_t>(0, write(fd2, out2.data() + sent2, std::min<size_t>(64, out2.size() - sent2)));
    pollfd p[2] = {{fd0, POLLIN, 0}, {fd2, POLLIN, 0}};
    poll(p, 2, 10);
    uint8_t buf[1024];
    if (p[0].revents & POLLIN) {
      const ssize_t n = read(fd0, buf, sizeof buf);
      if (n > 0) in0.insert(in0.end(), buf, buf + n);
    }
    if (p[1].revents & POLLIN) {
      const ssize_t n = read(fd2, buf, sizeof buf);
      if (n > 0) in2.insert(in2.end(), buf, buf + n);
    }
  }
  return in0;
}

TEST(AvrPil, BridgesBothUartsWithoutLosingAByte) {
  ASSERT_EQ(access(UART_ECHO_ELF, R_OK), 0) << UART_ECHO_ELF << " missing: run `make avr` first";
  quad_test::RawPty p0, p2;
  ASSERT_FALSE(p0.path.empty());
  ASSERT_FALSE(p2.path.empty());
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    execl(AVR_PIL_PATH, AVR_PIL_PATH, "--elf", UART_ECHO_ELF, "--uart0", p0.path.c_str(), "--uart2", p2.path.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  std::mt19937 rng(7);
  std::vector<uint8_t> out0(8000), out2(3000);
  for (auto& b : out0) b = static_cast<uint8_t>(rng());
  for (auto& b : out2) b = static_cast<uint8_t>(rng());
  std::vector<uint8_t> in2;
  const std::vector<uint8_t> in0 = exchange(p0.master, out0, p2.master, out2, in2, 60.0);
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_EQ(in0.size(), out0.size());
  EXPECT_EQ(in2.size(), out2.size());
  EXPECT_TRUE(in0 == out0) << "UART0 echo differs";
  EXPECT_TRUE(in2 == out2) << "UART2 echo differs";
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "avr_pil did not stop cleanly";
}

}  // namespace
