// Emulated serial links: pacing to the baud rate (in simulated time and through a real pty in real
// time), the radio model's loss, bit errors and latency, and determinism for a seed.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <poll.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include "quad/link/mavlink.h"
#include "quad/sim/pty.h"
#include "quad/sim/serial_line.h"

namespace quad::sim {
namespace {

std::vector<uint8_t> pattern(size_t n, uint8_t seed) {
  std::vector<uint8_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<uint8_t>(seed + 31 * i);
  return v;
}

TEST(SerialLine, PacesABacklogToTheBaudRateInSimulatedTime) {
  // The radio (57600) and UART0 (921600): a backlog of 2.5 s of bytes handed over at once, in 60-byte
  // frames; count the bytes that have arrived at each 0.1 s over 2 s.
  for (const double baud : {57600.0, 921600.0}) {
    SerialLine line(baud, Rng(1, "line"));
    const auto frame = pattern(60, 0);
    const int frames = static_cast<int>(2.5 * baud / 10.0 / 60.0);
    for (int i = 0; i < frames; ++i) line.send(frame.data(), frame.size(), 0.0);
    uint64_t arrived = 0;
    for (int k = 1; k <= 20; ++k) line.deliver_until(0.1 * k, [&](const uint8_t*, size_t n) { arrived += n; });
    const double rate = static_cast<double>(arrived) / 2.0;
    std::printf("simulated-time pacing: %.1f B/s at %.0f baud (%.2f %% of baud/10)\n", rate, baud,
                100.0 * rate / (baud / 10.0));
    EXPECT_NEAR(rate / (baud / 10.0), 1.0, 0.02) << rate << " B/s at " << baud;
    EXPECT_NEAR(line.busy_until(), frames * 60 * 10.0 / baud, 1e-9);
  }
}

TEST(SerialLine, AFrameArrivesAfterLatencyJitterAndItsOwnTransmission) {
  SerialLine line(57600, Rng(2, "line"));
  line.set_radio({0.020, 0.010, 0.0, 0.0});
  const auto frame = pattern(40, 1);
  const double wire = 40 * 10.0 / 57600.0;
  double sum = 0.0, last = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const double t = i * 0.1;  // far apart: no queueing
    line.send(frame.data(), frame.size(), t);
    double arrival = -1.0;
    for (double probe = t; arrival < 0.0 && probe < t + 1.0; probe += 1e-4)
      line.deliver_until(probe, [&](const uint8_t*, size_t) { arrival = probe; });
    ASSERT_GE(arrival, t + 0.020 + wire - 1e-4);
    ASSERT_LE(arrival, t + 0.030 + wire + 1e-4);
    ASSERT_GT(arrival, last);
    last = arrival;
    sum += arrival - t - wire;
  }
  EXPECT_NEAR(sum / 2000.0, 0.025, 0.0005) << "mean latency = latency + jitter / 2";
}

TEST(SerialLine, LossAndBitErrorRatesAreReproduced) {
  const double loss = 0.1, ber = 1e-4;
  SerialLine line(57600, Rng(3, "radio"));
  line.set_radio({0.0, 0.0, loss, ber});
  const int frames = 20000;
  const auto frame = pattern(50, 2);
  uint64_t differing_bits = 0, corrupted = 0, delivered = 0;
  for (int i = 0; i < frames; ++i) {
    line.send(frame.data(), frame.size(), i * 0.01);
    line.deliver_until(1e9, [&](const uint8_t* d, size_t n) {
      ASSERT_EQ(n, frame.size());
      ++delivered;
      uint64_t bits = 0;
      for (size_t k = 0; k < n; ++k) bits += static_cast<uint64_t>(__builtin_popcount(d[k] ^ frame[k]));
      differing_bits += bits;
      corrupted += bits > 0;
    });
  }
  const LineStats& s = line.stats();
  EXPECT_EQ(s.frames_sent, static_cast<uint64_t>(frames));
  EXPECT_EQ(s.frames_lost + delivered, static_cast<uint64_t>(frames));
  EXPECT_EQ(s.bits_flipped, differing_bits) << "the statistics count what the receiver sees";
  EXPECT_EQ(s.frames_corrupted, corrupted);
  // Loss: binomial, 4 sigma.
  const double lost_fraction = static_cast<double>(s.frames_lost) / frames;
  std::printf("loss %.4f (configured %.4f), bit errors %llu in %.0f bits = %.3g (configured %.3g)\n", lost_fraction, loss,
              static_cast<unsigned long long>(differing_bits), 400.0 * static_cast<double>(delivered),
              static_cast<double>(differing_bits) / (400.0 * static_cast<double>(delivered)), ber);
  EXPECT_NEAR(lost_fraction, loss, 4.0 * std::sqrt(loss * (1 - loss) / frames));
  // Bit errors: Poisson over the delivered bits, 4 sigma.
  const double bits = 400.0 * static_cast<double>(delivered);
  EXPECT_NEAR(static_cast<double>(differing_bits), ber * bits, 4.0 * std::sqrt(ber * bits));
  const double p_corrupt = 1.0 - std::pow(1.0 - ber, 400.0);
  EXPECT_NEAR(static_cast<double>(corrupted) / static_cast<double>(delivered), p_corrupt,
              4.0 * std::sqrt(p_corrupt * (1 - p_corrupt) / static_cast<double>(delivered)));
}

TEST(SerialLine, TheParserRejectsExactlyTheCorruptedFrames) {
  SerialLine line(57600, Rng(4, "radio"));
  line.set_radio({0.005, 0.002, 0.05, 2e-4});
  mavlink::Sender sender(1, 197);
  mavlink::Parser parser;
  uint64_t accepted = 0;
  for (int i = 0; i < 3000; ++i) {
    mavlink::LandingTarget lt;
    lt.time_usec = static_cast<uint64_t>(i) * 33333u;
    lt.x = 0.1f * static_cast<float>(i % 7);
    lt.frame = mavlink::kFrameBodyFrd;
    lt.position_valid = 1;
    uint8_t buf[mavlink::max_frame_length<mavlink::LandingTarget>()];
    const size_t n = sender.encode(lt, buf, sizeof buf);
    line.send(buf, n, i / 30.0);
    line.deliver_until(i / 30.0, [&](const uint8_t* d, size_t len) {
      parser.feed(d, len, [&](const mavlink::Frame& f) { accepted += f.message_id == mavlink::LandingTarget::kId; });
    });
  }
  line.deliver_until(1e9, [&](const uint8_t* d, size_t len) {
    parser.feed(d, len, [&](const mavlink::Frame& f) { accepted += f.message_id == mavlink::LandingTarget::kId; });
  });
  const LineStats& s = line.stats();
  EXPECT_GT(s.frames_corrupted, 100u);
  EXPECT_EQ(accepted, s.frames_sent - s.frames_lost - s.frames_corrupted);
  // The receiver's sequence-gap count sees both the lost and the rejected frames.
  EXPECT_EQ(parser.stats().sequence_lost, s.frames_lost + s.frames_corrupted);
}

TEST(SerialLine, TheSameSeedGivesTheSameBytesAtTheSameTimes) {
  auto run = [](uint64_t seed) {
    SerialLine line(57600, Rng(seed, "radio"));
    line.set_radio({0.01, 0.02, 0.1, 1e-3});
    std::vector<std::pair<double, std::vector<uint8_t>>> out;
    const auto frame = pattern(30, 5);
    for (int i = 0; i < 500; ++i) {
      line.send(frame.data(), frame.size(), i * 0.004);
      line.deliver_until(i * 0.004, [&](const uint8_t* d, size_t n) { out.push_back({i * 0.004, {d, d + n}}); });
    }
    return out;
  };
  EXPECT_EQ(run(42), run(42));
  EXPECT_NE(run(42), run(43));
}

TEST(Pty, RealTimePacingThroughAPseudoTerminalMatchesTheBaud) {
  // Real time: the line's clock is the wall clock; the reader is a separate thread on the slave end.
  const int baud = 57600;
  Pty pty(baud);
  const int reader_fd = open(pty.slave_path().c_str(), O_RDONLY | O_NOCTTY);
  ASSERT_GE(reader_fd, 0);
  const size_t total = 7200;  // 1.25 s at 5760 B/s
  std::atomic<bool> done{false};
  std::chrono::steady_clock::time_point first, last;
  size_t received = 0;
  std::thread reader([&] {
    uint8_t buf[512];
    while (received < total) {
      pollfd p{reader_fd, POLLIN, 0};
      if (poll(&p, 1, 2000) <= 0) break;
      const ssize_t n = read(reader_fd, buf, sizeof buf);
      if (n <= 0) break;
      const auto now = std::chrono::steady_clock::now();
      if (received == 0) first = now;
      received += static_cast<size_t>(n);
      last = now;
    }
    done = true;
  });
  SerialLine line(baud, Rng(1, "line"));
  const auto start = std::chrono::steady_clock::now();
  auto now_s = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const auto frame = pattern(48, 9);
  for (size_t i = 0; i < total / frame.size(); ++i) line.send(frame.data(), frame.size(), 0.0);
  while (!line.idle()) {
    line.deliver_until(now_s(), [&](const uint8_t* d, size_t n) { pty.write_all(d, n); });
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  reader.join();
  close(reader_fd);
  ASSERT_EQ(received, total);
  // The first chunk arrives one frame in; the rest is paced: (total - first frame) bytes over the span.
  const double span = std::chrono::duration<double>(last - first).count();
  const double rate = static_cast<double>(total - frame.size()) / span;
  std::printf("real-time pty pacing: %.1f B/s for %d baud (%.2f %% of baud/10)\n", rate, baud, 100.0 * rate / (baud / 10.0));
  EXPECT_NEAR(rate / (baud / 10.0), 1.0, 0.02) << rate << " B/s";
}

}  // namespace
}  // namespace quad::sim
