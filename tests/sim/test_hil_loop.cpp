// The HIL loop end to end against a stand-in firmware (fake_firmware.cpp) that speaks the protocol:
// lockstep exchanges, vision fixes across the emulated radio in body FRD, ground-station commands,
// telemetry in the log, determinism for a seed, and runs cut short.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "quad/link/mavlink.h"
#include "quad/sim/hil_session.h"
#include "quad/sim/scenario.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {

const char* kScenario = R"(
name: loop
duration_s: 3
seed: 3
initial: {north_east_m: [1.0, -0.5], yaw_deg: 0}
vision: {rate_hz: 30, latency_s: 0.03, noise_m: 0.005}
commands:
  - {at_s: 1.5, arm: true}
)";

std::string temp_dir(const std::string& name) {
  return std::string(::testing::TempDir()) + "/quad_sim_" + name + "_" + std::to_string(::getpid());
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The log as columns.
std::map<std::string, std::vector<double>> read_log(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  for (std::stringstream h(line); std::getline(h, line, ',');) names.push_back(line);
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(in, line)) {
    std::stringstream r(line);
    std::string cell;
    for (size_t i = 0; std::getline(r, cell, ','); ++i) cols[names.at(i)].push_back(std::stod(cell));
  }
  return cols;
}

// A number in summary.json: the first "key": after the first occurrence of "section".
double json_number(const std::string& json, const std::string& key, const std::string& section) {
  const size_t from = json.find("\"" + section + "\"");
  const size_t at = json.find("\"" + key + "\": ", from);
  return at == std::string::npos ? NAN : std::stod(json.substr(at + key.size() + 4));
}

SessionResult fly(const Scenario& s, const std::string& out, const std::atomic<bool>* stop = nullptr,
                  std::vector<std::string> firmware = {QUAD_SIM_FAKE_FIRMWARE}) {
  SessionOptions o;
  o.out_dir = out;
  o.firmware_argv = std::move(firmware);
  o.progress = false;
  o.stop = stop;
  o.answer_timeout_s = 2.0;
  return run_session(s, o);
}

TEST(HilLoop, LockstepVisionCommandsAndTelemetry) {
  const Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  const std::string out = temp_dir("loop");
  const SessionResult r = fly(s, out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_NEAR(r.sim_time_s, 3.0, 1e-9);
  const std::string summary = slurp(out + "/summary.json");
  EXPECT_NE(summary.find("\"complete\": true"), std::string::npos);
  EXPECT_NE(summary.find("\"lockstep_exchanges\": 300"), std::string::npos) << "one exchange per 10 ms";
  auto log = read_log(out + "/log.csv");
  ASSERT_EQ(log["t"].size(), 300u);
  // Before arming: the vehicle rests at (1, -0.5); the fake firmware's estimate is -p_B of the last
  // LANDING_TARGET, i.e. the noisy vision position: it must match the truth in N and E (FRD -> NED
  // signs), 40 ms old but the vehicle is still.
  int checked = 0;
  for (size_t i = 0; i < 140; ++i) {
    if (std::isnan(log["est_n"][i])) continue;
    EXPECT_NEAR(log["est_n"][i], log["true_n"][i], 0.03);
    EXPECT_NEAR(log["est_e"][i], log["true_e"][i], 0.03);
    EXPECT_NEAR(log["est_d"][i], log["true_d"][i], 0.03);
    ++checked;
  }
  EXPECT_GT(checked, 100);
  // The arm command crossed UART0, the heartbeat came back: armed from just after 1.5 s.
  EXPECT_EQ(log["armed"][140], 0.0);
  EXPECT_EQ(log["armed"].back(), 1.0);
  EXPECT_EQ(log["mode"].back(), 1.0);
  // Armed, the fake commands 1.1 x hover on every rotor: the vehicle must climb, level.
  EXPECT_LT(log["true_d"].back(), log["true_d"][140] - 0.3);
  EXPECT_LT(std::abs(log["true_roll"].back()) + std::abs(log["true_pitch"].back()), 1e-3);
  // 30 Hz vision over 3 s crossed the radio; the fake's heartbeats came back down it.
  EXPECT_NEAR(log["radio_up_sent"].back(), 90.0, 1.0);
  EXPECT_GE(json_number(summary, "frames_received", "ground_station_received"), 29.0);
  // At rest, before arming, the IMU reads about (0, 0, -g) in FRD.
  EXPECT_NEAR(log["imu_az"][50], -9.80665, 0.5);
}

// Each fault of a scenario shows in the log where, and only where, it is active. The sensor faults act
// while the vehicle stands still on the ground; the stand-in firmware has no attitude control, so the
// motor fault is checked on the thrusts alone.
TEST(HilLoop, FaultsActOnTheirSubsystemDuringTheirWindow) {
  const Scenario s = parse_scenario(R"(
name: faults
duration_s: 4
seed: 9
commands:
  - {at_s: 2.5, arm: true}
faults:
  - {type: gyro_bias_step, start_s: 0.5, end_s: 1.5, bias_rad_s: [0.0, 0.0, 0.2]}
  - {type: mag_disturbance, start_s: 1.0, end_s: 2.0, field_ned_gauss: [0.0, 0.0, 0.5]}
  - {type: radio_loss, start_s: 2.0, end_s: 2.5}
  - {type: vision_dropout, start_s: 3.0, end_s: 3.5}
  - {type: rc_loss, start_s: 3.0, end_s: 3.5}
  - {type: motor_efficiency, start_s: 3.0, end_s: 3.5, motor: 2, efficiency: 0.5}
)", "faults.yaml", ".");
  const std::string out = temp_dir("faults");
  ASSERT_TRUE(fly(s, out).complete);
  auto log = read_log(out + "/log.csv");
  auto at = [&](const char* col, double t) { return log[col][static_cast<size_t>(std::lround(t * 100.0)) - 1]; };
  auto mean = [&](const char* col, double t0, double t1) {
    double sum = 0.0;
    int n = 0;
    for (size_t i = 0; i < log["t"].size(); ++i)
      if (log["t"][i] > t0 && log["t"][i] <= t1) sum += log[col][i], ++n;
    return sum / n;
  };
  // The gyro's z reads the step once the DLPF has settled, not before or after.
  EXPECT_NEAR(mean("imu_gz", 0.7, 1.5), 0.2, 0.005);
  EXPECT_NEAR(mean("imu_gz", 0.1, 0.5), 0.0, 0.01);
  EXPECT_NEAR(mean("imu_gz", 1.7, 2.5), 0.0, 0.01);
  // 0.5 G more along NED down reads as +0.5 G times D_33 (eq. 7.6, about 1.01) on body z, level.
  EXPECT_NEAR(mean("mag_z", 1.1, 2.0) - mean("mag_z", 0.1, 1.0), 0.5 * 1.01, 0.01);
  EXPECT_NEAR(mean("mag_z", 2.1, 2.5) - mean("mag_z", 0.1, 1.0), 0.0, 0.01);
  // Radio loss: every uplink frame of the window is lost (15 at 30 Hz), none outside it.
  EXPECT_EQ(at("radio_up_lost", 2.0), 0.0);
  EXPECT_NEAR(at("radio_up_lost", 2.5), 15.0, 1.0);
  EXPECT_EQ(at("radio_up_lost", 4.0), at("radio_up_lost", 2.5));
  // Vision dropout: nothing captured in the window reaches the radio (the last earlier capture, at
  // 2.967 s, is handed over 22 ms later); 30 Hz outside it.
  EXPECT_EQ(at("vision_sent", 3.5) - at("vision_sent", 3.1), 0.0);
  EXPECT_NEAR(at("vision_sent", 2.9) - at("vision_sent", 2.5), 12.0, 1.0);
  // RC loss: UART0 carries only HIL_SENSOR (100 Hz), without MANUAL_CONTROL (50 Hz).
  EXPECT_EQ(at("uart0_tx_frames", 3.4) - at("uart0_tx_frames", 3.1), 30.0);
  EXPECT_EQ(at("uart0_tx_frames", 2.9) - at("uart0_tx_frames", 2.6), 45.0);
  // Motor 2 gives half its thrust inside the window (the stand-in commands all four alike).
  EXPECT_NEAR(at("thrust2", 3.3) / at("thrust0", 3.3), 0.5, 0.01);
  EXPECT_NEAR(at("thrust2", 3.7) / at("thrust0", 3.7), 1.0, 0.01);
}

// An outside program at the base station (the vision station) writes its fixes into the ground port;
// they cross the radio to the firmware, and the firmware's radio output comes back out of the port.
TEST(HilLoop, TheGroundPortCarriesAnOutsideStationsFixesAcrossTheRadio) {
  Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  s.vision.enabled = false;  // the outside station makes the fixes
  s.commands.clear();
  SessionOptions o;
  o.out_dir = temp_dir("ground");
  o.firmware_argv = {QUAD_SIM_FAKE_FIRMWARE};
  o.progress = false;
  o.ground_port_link = o.out_dir + "_radio";
  std::atomic<bool> done{false};
  std::atomic<int> heartbeats{0};
  std::thread station([&] {
    int fd = -1;
    while (!done && (fd = open(o.ground_port_link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK)) < 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (fd < 0) return;
    termios tio{};
    tcgetattr(fd, &tio);
    cfmakeraw(&tio);
    tcsetattr(fd, TCSANOW, &tio);
    mavlink::Sender sender(1, mavlink::kCompIdVisualInertialOdometry);
    mavlink::Parser parser;
    while (!done) {
      mavlink::LandingTarget lt;  // the star 2 m below and 0.25 m behind: vehicle at (0.25, 0, -2) NED, level
      lt.frame = mavlink::kFrameBodyFrd;
      lt.x = -0.25f;
      lt.z = 2.0f;
      lt.position_valid = 1;
      uint8_t buf[mavlink::max_frame_length<mavlink::LandingTarget>()];
      (void)!write(fd, buf, sender.encode(lt, buf, sizeof buf));
      uint8_t in[512];
      for (ssize_t n; (n = read(fd, in, sizeof in)) > 0;)
        parser.feed(in, static_cast<size_t>(n), [&](const mavlink::Frame& f) { heartbeats += f.message_id == 0; });
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    close(fd);
  });
  const SessionResult r = run_session(s, o);
  done = true;
  station.join();
  ASSERT_TRUE(r.complete) << r.reason;
  auto log = read_log(o.out_dir + "/log.csv");
  EXPECT_NEAR(log["est_n"].back(), 0.25, 1e-6) << "the fix arrived (the stand-in reports -p_B)";
  EXPECT_NEAR(log["est_d"].back(), -2.0, 1e-6);
  EXPECT_GT(log["radio_up_sent"].back(), 0.0);
  EXPECT_GT(heartbeats.load(), 0) << "the firmware's radio output came out of the ground port";
  EXPECT_NE(access(o.ground_port_link.c_str(), F_OK), 0) << "the link is removed at the end";
}

// The fake firmware's "fix CAPTURE_US SEEN_US" lines (--log-fixes), in seconds: when each LANDING_TARGET
// was captured and the HIL time of the step at which the firmware read it off UART2.
std::vector<std::pair<double, double>> fixes_seen(const std::string& firmware_log) {
  std::vector<std::pair<double, double>> out;
  std::istringstream in(slurp(firmware_log));
  for (std::string line; std::getline(in, line);) {
    unsigned long long capture = 0, seen = 0;
    if (std::sscanf(line.c_str(), "fix %llu %llu", &capture, &seen) == 2) out.emplace_back(capture * 1e-6, seen * 1e-6);
  }
  return out;
}

// A radio_latency fault delays every frame crossing the radio by its latency instead of the radio's,
// from its start to its end; before it the radio's own latency holds, and after it too once the frames
// held back by it (no overtaking) have arrived. No jitter, so each vision fix's way is known: 22 ms to
// the radio, the radio latency, its 72 bytes at 57600 baud (12.5 ms), then the first 100 Hz step at or
// after its arrival (one more if the pty is slow to hand the bytes over).
TEST(HilLoop, RadioLatencyFaultDelaysTheRadioFramesOnlyInItsWindow) {
  const Scenario s = parse_scenario(R"(
name: radio_latency
duration_s: 3.2
seed: 5
radio: {baud: 57600, latency_s: 0.004, jitter_s: 0.0}
vision: {rate_hz: 30, latency_s: 0.022, noise_m: 0.005}
faults:
  - {type: radio_latency, start_s: 1.0, end_s: 2.0, latency_s: 0.1}
)", "radio_latency.yaml", ".");
  const std::string out = temp_dir("radio_latency");
  const SessionResult r = fly(s, out, nullptr, {QUAD_SIM_FAKE_FIRMWARE, "--log-fixes"});
  ASSERT_TRUE(r.complete) << r.reason;
  const auto fixes = fixes_seen(out + "/firmware.log");
  ASSERT_GT(fixes.size(), 85u) << "30 Hz for 3.2 s";
  const double wire = static_cast<double>(mavlink::max_frame_length<mavlink::LandingTarget>()) * 10.0 / 57600.0;
  const double period = 0.01;
  std::vector<double> before, during, after;
  double last_seen = 0.0;
  for (const auto& [capture, seen] : fixes) {
    EXPECT_GE(seen, last_seen) << "a frame overtook another at capture " << capture;
    last_seen = seen;
    const double to_radio = capture + 0.022, delay = seen - capture;
    double radio_latency = 0.0;
    if (to_radio < 0.99) {
      before.push_back(delay);
      radio_latency = 0.004;
    } else if (to_radio >= 1.01 && to_radio < 1.99) {
      during.push_back(delay);
      radio_latency = 0.1;
    } else if (to_radio >= 2.0 + 0.1 + wire + period) {  // the frames held back by the fault are through
      after.push_back(delay);
      radio_latency = 0.004;
    } else {
      continue;  // at the window's edges
    }
    const double arrival = 0.022 + radio_latency + wire;
    EXPECT_GE(delay, arrival - 1e-6) << "capture " << capture;
    EXPECT_LE(delay, arrival + 2.0 * period + 1e-6) << "capture " << capture;
  }
  ASSERT_GE(before.size(), 25u);
  ASSERT_GE(during.size(), 25u);
  ASSERT_GE(after.size(), 25u);
  auto mean = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v) sum += x;
    return sum / static_cast<double>(v.size());
  };
  std::printf("vision fix capture -> firmware: %.1f ms before the fault, %.1f ms during (latency 0.1 s), %.1f ms after\n",
              1e3 * mean(before), 1e3 * mean(during), 1e3 * mean(after));
  // The step grid adds the same 0-10 ms in every window (30 Hz captures against 100 Hz steps): the
  // means differ by the latencies' difference.
  EXPECT_NEAR(mean(during) - mean(before), 0.1 - 0.004, 0.003);
  EXPECT_NEAR(mean(after) - mean(before), 0.0, 0.003);
}

// UART0 from the firmware is counted and paced too: per exchange, the firmware's frames since its last
// answer up to and including this one; the answer's commands take effect when its last byte arrives at
// 921600 baud, behind the HIL_SENSOR and the firmware's other bytes; an answer that arrives after the end
// of its period is an overrun. The stand-in pads every answer with K TIMESYNC frames of 30 bytes.
TEST(HilLoop, UartZeroFromTheFirmwareIsCountedAndPacedAtItsBaud) {
  const Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  auto run = [&](const std::string& name, int pad_frames) {
    const std::string out = temp_dir(name);
    std::vector<std::string> fw{QUAD_SIM_FAKE_FIRMWARE};
    if (pad_frames > 0) fw.insert(fw.end(), {"--pad-frames", std::to_string(pad_frames)});
    const SessionResult r = fly(s, out, nullptr, fw);
    EXPECT_TRUE(r.complete) << r.reason;
    return out;
  };
  const std::string plain = run("uart0_plain", 0), padded = run("uart0_pad", 10), padded_again = run("uart0_pad2", 10),
                    flooded = run("uart0_flood", 32);
  const std::string a = slurp(plain + "/summary.json"), b = slurp(padded + "/summary.json"),
                    c = slurp(flooded + "/summary.json");
  const std::string in = "uart0_from_firmware";
  const double byte_s = 10.0 / 921600.0, pad_bytes = 10.0 * (mavlink::kHeaderLength + mavlink::Timesync::kLength +
                                                             mavlink::kChecksumLength);
  ASSERT_EQ(pad_bytes, 300.0);
  EXPECT_EQ(json_number(a, "budget_bytes_per_period", in), 921.6) << "921600 baud, 100 Hz, 10 bits a byte";
  // The stand-in's answers (and its heartbeats and positions every 10th step) are counted.
  const double plain_bytes = json_number(a, "bytes_received", in);
  EXPECT_GT(plain_bytes, 300.0 * 20.0);
  EXPECT_GE(json_number(a, "bytes_per_exchange_max", in), 20.0);
  // Padding adds exactly its bytes to every one of the 300 exchanges...
  EXPECT_EQ(json_number(b, "bytes_received", in) - plain_bytes, 300.0 * pad_bytes);
  EXPECT_NEAR(json_number(b, "bytes_per_exchange_mean", in) - json_number(a, "bytes_per_exchange_mean", in), pad_bytes, 1e-6);
  // ...and their time on the wire to every answer's delay (3.26 ms), still inside the 10 ms period.
  const double delay_plain = json_number(a, "answer_delay_s_mean", in);
  EXPECT_GT(delay_plain, 0.0005) << "HIL_SENSOR out and the answer back take time on the wire";
  EXPECT_LT(delay_plain, 0.003);
  EXPECT_NEAR(json_number(b, "answer_delay_s_mean", in) - delay_plain, pad_bytes * byte_s, 1e-7);
  EXPECT_EQ(json_number(a, "overruns", in), 0.0);
  EXPECT_EQ(json_number(b, "overruns", in), 0.0);
  // The later commands change the flight once they matter (armed at 1.5 s), not before; and the accounting
  // is deterministic: the same run again gives the same log.
  const auto log_plain = read_log(plain + "/log.csv"), log_padded = read_log(padded + "/log.csv");
  EXPECT_EQ(log_plain.at("true_d")[140], log_padded.at("true_d")[140]);
  EXPECT_NE(log_plain.at("thrust0")[160], log_padded.at("thrust0")[160]);
  EXPECT_EQ(slurp(padded + "/log.csv"), slurp(padded_again + "/log.csv"));
  // 32 frames (960 bytes, 10.4 ms) do not fit a 10 ms period: every answer is late, and later and later.
  EXPECT_EQ(json_number(c, "overruns", in), 300.0);
  EXPECT_GT(json_number(c, "answer_delay_s_max", in), 0.1);
  EXPECT_NE(slurp(flooded + "/events.log").find("do not fit 921600 baud"), std::string::npos);
}

TEST(HilLoop, RealTimeModeFliesOnTheWallClock) {
  Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  s.duration_s = 1.0;
  s.commands.clear();
  SessionOptions o;
  o.out_dir = temp_dir("realtime");
  o.firmware_argv = {QUAD_SIM_FAKE_FIRMWARE};
  o.progress = false;
  o.realtime = true;
  const SessionResult r = run_session(s, o);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_GT(r.wall_time_s, 0.95);
  EXPECT_LT(r.wall_time_s, 1.5);
  const std::string summary = slurp(o.out_dir + "/summary.json");
  EXPECT_NE(summary.find("\"mode\": \"realtime\""), std::string::npos);
  // About 100 HIL_SENSOR in the wall-clock second; answers must be used for most of them. Not a speed
  // test: under the sanitizers on a loaded machine the stand-in answers later (77 seen), so the bound
  // only catches a loop that ignores the answers.
  EXPECT_GT(json_number(summary, "lockstep_exchanges", "real_time_factor"), 50.0) << "answers used";
  // The firmware is told the mode (HIL_LOCKSTEP 0); the stand-in flags lockstep regardless, which the
  // run notes once and survives.
  EXPECT_NE(slurp(o.out_dir + "/firmware_params.txt").find("HIL_LOCKSTEP 0\n"), std::string::npos);
  const std::string events = slurp(o.out_dir + "/events.log");
  const std::string mismatch = "firmware answers flagged lockstep in a real-time run";
  EXPECT_NE(events.find(mismatch), std::string::npos) << events;
  EXPECT_EQ(events.find(mismatch), events.rfind(mismatch)) << "said once";
}

TEST(HilLoop, TheSameSeedGivesTheSameLog) {
  Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  const std::string a = temp_dir("seed_a"), b = temp_dir("seed_b"), c = temp_dir("seed_c");
  ASSERT_TRUE(fly(s, a).complete);
  ASSERT_TRUE(fly(s, b).complete);
  s.seed = 4;
  ASSERT_TRUE(fly(s, c).complete);
  EXPECT_EQ(slurp(a + "/log.csv"), slurp(b + "/log.csv"));
  EXPECT_NE(slurp(a + "/log.csv"), slurp(c + "/log.csv"));
}

TEST(HilLoop, AnInterruptedRunLeavesAReadableLogAndSaysSo) {
  const Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  const std::string out = temp_dir("stop");
  std::atomic<bool> stop{false};
  SessionOptions o;
  o.out_dir = out;
  o.firmware_argv = {QUAD_SIM_FAKE_FIRMWARE};
  o.progress = false;
  o.stop = &stop;
  o.on_frame = [&](Vehicle& v) { stop = v.time() >= 1.0; };
  const SessionResult r = run_session(s, o);
  EXPECT_FALSE(r.complete);
  EXPECT_EQ(r.reason, "interrupted");
  const std::string summary = slurp(out + "/summary.json");
  EXPECT_NE(summary.find("\"complete\": false"), std::string::npos);
  EXPECT_NE(summary.find("\"cut_short\": \"interrupted\""), std::string::npos);
  const auto log = read_log(out + "/log.csv");
  EXPECT_NEAR(static_cast<double>(log.at("t").size()), 100.0, 5.0);
}

TEST(HilLoop, ASilentFirmwareEndsTheRunWithAReason) {
  const Scenario s = parse_scenario(kScenario, "loop.yaml", ".");
  // A process that opens nothing and says nothing (the port arguments land in $0, $1, ...).
  const SessionResult r = fly(s, temp_dir("silent"), nullptr, {"sh", "-c", "sleep 30"});
  EXPECT_FALSE(r.complete);
  EXPECT_NE(r.reason.find("did not answer HIL_SENSOR at t = 0"), std::string::npos) << r.reason;
  // One that exits at once.
  const SessionResult dead = fly(s, temp_dir("dead"), nullptr, {"sh", "-c", "exit 7"});
  EXPECT_NE(dead.reason.find("exited with status 7"), std::string::npos) << dead.reason;
  // One that does not exist.
  try {
    fly(s, temp_dir("missing"), nullptr, {"/nonexistent/quad_firmware"});
    ADD_FAILURE() << "no error for a missing firmware";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("cannot start the firmware '/nonexistent/quad_firmware'"), std::string::npos);
  }
}

}  // namespace
}  // namespace quad::sim
