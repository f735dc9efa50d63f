// The replay tool's log reader (errors name line and column) and the whole replay chain on a synthetic
// log: attitude, kinematic acceleration, delayed vision fixes, CSV output. Then the executable itself:
// every option (filter choice, propagator, gains, position filter settings), its errors, and the
// README's hand-written example.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "attitude_sim.h"
#include "replay.h"
#include "sensor_log.h"

namespace {

using quad::replay::LogError;
using quad::replay::read_log;

std::string error_of(const std::string& text) {
  std::istringstream in(text);
  try {
    read_log(in, "log.csv");
  } catch (const LogError& e) {
    return e.what();
  }
  return "";
}

const char* kHeader = "t,gx,gy,gz,ax,ay,az,mx,my,mz,vis_t,vis_x,vis_y,vis_z\n";

TEST(ReplayLog, ErrorsNameLineAndColumn) {
  EXPECT_EQ(error_of("t,gx,gz,ax,ay,az,mx,my,mz\n0,0,0,0,0,-9.8,1,0,0\n"), "log.csv:1: missing column 'gy' in the header");
  EXPECT_EQ(error_of("# comment\nt,gx,gy,gz,ax,ay,az,mx,my,mz,vis_t,vis_x\n"),
            "log.csv:2: missing column 'vis_y' in the header");
  EXPECT_EQ(error_of(std::string(kHeader) + "0,0,0,0,0,0,-9.8,1,0,0,,,,\n0.01,0,0,0,0,abc,-9.8,1,0,0,,,,\n"),
            "log.csv:3: column 'ay' (6): not a finite number: 'abc'");
  EXPECT_EQ(error_of(std::string(kHeader) + "0,0,0,0,0,0,-9.8,1,0,0,,,,\n\n0.01,0,0,,0,0,-9.8,1,0,0,,,,\n"),
            "log.csv:4: column 'gz' (4): empty cell");
  EXPECT_EQ(error_of(std::string(kHeader) + "0.02,0,0,0,0,0,-9.8,1,0,0,,,,\n0.01,0,0,0,0,0,-9.8,1,0,0,,,,\n"),
            "log.csv:3: column 't' (1): time goes backwards (0.01 s after 0.02 s on line 2)");
  EXPECT_EQ(error_of(std::string(kHeader) + "0,0,0,0,0,0,-9.8,1,0,0,0,1,,3\n"),
            "log.csv:2: column 'vis_y' (13): empty cell in a partly filled vision fix");
  EXPECT_EQ(error_of(std::string(kHeader) + "0,0,0,0,0,0,-9.8,1,,0,,,,\n"),
            "log.csv:2: column 'my' (9): empty cell in a partly filled magnetometer sample");
  EXPECT_EQ(error_of(std::string(kHeader) + "0,0,0,0,0,0,-9.8,1,0,0,0.5,1,2,3\n"),
            "log.csv:2: column 'vis_t' (11): vision fix captured at 0.5 s, after the row's time 0 s");
  EXPECT_EQ(error_of(std::string(kHeader) + "0,0,0,0,0,0,-9.8,1,0,0,,,,nan\n"),
            "log.csv:2: column 'vis_z' (14): not a finite number: 'nan'");
  EXPECT_EQ(error_of(kHeader), "log.csv: no data rows after the header");
  // Valid: columns in any order, extra columns, CRLF line ends, no vision columns, missing mag sample.
  std::istringstream ok("extra,mz,my,mx,az,ay,ax,gz,gy,gx,t\r\nx,0.45,0,0.2,-9.8,0,0,0,0,0,0\r\ny,,,,-9.8,0,0,0,0,0,0.01\r\n");
  const auto rows = read_log(ok, "ok.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_DOUBLE_EQ((*rows[0].mag)[2], 0.45);
  EXPECT_FALSE(rows[1].mag.has_value());
  EXPECT_FALSE(rows[0].fix.has_value());
}

TEST(Replay, SyntheticFlightThroughTheWholeChain) {
  // A tumbling vehicle that also translates: truth attitude from AttitudeSim, truth position
  // p(t) = (sin 0.5t, 0.5 cos 0.3t, -1.5 + 0.2 sin 0.7t); specific force a_B = R^T (p'' - g e_z); fixes at
  // 30 Hz delivered 60 ms late; magnetometer at 50 Hz.
  quad_test::AttitudeSim sim(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())), true, 3,
                             quad_test::mpu6000_noise());
  auto pos = [](double t) { return Eigen::Vector3d(std::sin(0.5 * t), 0.5 * std::cos(0.3 * t), -1.5 + 0.2 * std::sin(0.7 * t)); };
  auto acc = [](double t) {
    return Eigen::Vector3d(-0.25 * std::sin(0.5 * t), -0.045 * std::cos(0.3 * t), -0.098 * std::sin(0.7 * t));
  };
  std::ostringstream log;
  log << kHeader;
  std::vector<Eigen::Quaterniond> q_true;
  std::vector<Eigen::Vector3d> p_true;
  double next_fix = 0.0;
  const double dt = 0.01, delay = 0.06;
  std::vector<std::pair<double, Eigen::Vector3d>> pending;
  for (int k = 0; k < 3000; ++k) {
    const double t = k * dt;
    const quad_test::Sample s = sim.sample();
    const Eigen::Matrix3d r = sim.q().toRotationMatrix();
    // The simulated accelerometer reads -g R^T e_z (+ noise); add the translational part R^T p''.
    const Eigen::Vector3d a = r.transpose() * acc(t) + quad_test::to_eigen(s.accel);
    if (t + 1e-9 >= next_fix) {
      pending.emplace_back(t, pos(t));
      next_fix += 1.0 / 30.0;
    }
    log << t << "," << s.gyro.x << "," << s.gyro.y << "," << s.gyro.z << "," << a.x() << "," << a.y() << "," << a.z();
    if (k % 2 == 0) log << "," << s.mag.x << "," << s.mag.y << "," << s.mag.z;
    else log << ",,,";
    if (!pending.empty() && pending.front().first + delay <= t + 1e-9) {
      log << "," << pending.front().first << "," << pending.front().second.x() << "," << pending.front().second.y()
          << "," << pending.front().second.z() << "\n";
      pending.erase(pending.begin());
    } else {
      log << ",,,,\n";
    }
    q_true.push_back(sim.q());
    p_true.push_back(pos(t));
    sim.step(dt);
  }
  std::istringstream in(log.str());
  const auto rows = read_log(in, "synthetic.csv");
  quad::replay::ReplayOptions o;
  o.observer.mag_ref_ned = quad_test::from_eigen(sim.field());
  o.observer.mag_ref_from_init = false;
  o.position.process_noise = quad::est::ProcessNoise::kWhiteAcceleration;
  o.position.q_accel = 0.01f;
  o.position.fix_sigma_xy = o.position.fix_sigma_z = 0.01f;
  std::ostringstream out;
  const auto summary = quad::replay::replay(rows, o, out);
  EXPECT_EQ(summary.rows, 3000);
  EXPECT_EQ(summary.position.fused + 1, static_cast<uint32_t>(summary.fixes));  // the first one initialises

  // Parse our own output back and compare with the truth over the last 20 s.
  std::istringstream res(out.str());
  std::string line;
  std::getline(res, line);
  EXPECT_EQ(line, quad::replay::kOutputHeader);
  double att2 = 0, pos2 = 0;
  int n = 0, k = 0;
  while (std::getline(res, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) v.push_back(cell.empty() ? NAN : std::stod(cell));
    if (!line.empty() && line.back() == ',') v.push_back(NAN);  // getline drops a trailing empty cell
    ASSERT_EQ(v.size(), 17u) << line;
    if (k >= 1000) {
      // Row k holds the estimate after processing row k; the truth advanced by one step meanwhile.
      const Eigen::Quaterniond q(v[1], v[2], v[3], v[4]);
      att2 += std::pow(quad_test::rotation_distance(q, q_true[static_cast<size_t>(std::min(k + 1, 2999))]), 2);
      pos2 += (Eigen::Vector3d(v[11], v[12], v[13]) - p_true[static_cast<size_t>(k)]).squaredNorm();
      ++n;
    }
    ++k;
  }
  const double att_rms = std::sqrt(att2 / n) * 180 / M_PI, pos_rms = std::sqrt(pos2 / n);
  std::cout << "[figure] replay of a synthetic 30 s flight (fixes 60 ms late): attitude RMS " << att_rms
            << " deg, position RMS " << pos_rms * 1e3 << " mm\n";
  // The accelerometer sees up to 0.25 m/s^2 of manoeuvre, i.e. an apparent vertical up to 1.5 deg off.
  EXPECT_LT(att_rms, 1.5);
  EXPECT_LT(pos_rms, 0.03);
}


// ---------------------------------------------------------------------------------------------------------
// The executable (tools/estimation_replay/src/main.cpp): every option is accepted and does what it says,
// bad names and values stop it with exit status 2, and the README's hand-written example.

struct ToolRun {
  int status = -1;  // exit status; -1 if the tool did not exit normally (signal)
  std::string out, err;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Logs written by the tests, removed when the test program ends.
struct TempFiles {
  std::vector<std::string> paths;
  ~TempFiles() {
    for (const std::string& p : paths) std::remove(p.c_str());
  }
};
TempFiles& temp_files() {
  static TempFiles files;
  return files;
}

std::string temp_path(const std::string& stem) {
  static int counter = 0;
  return ::testing::TempDir() + "replay_tool_" + std::to_string(getpid()) + "_" + std::to_string(counter++) + "_" +
         stem;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs estimation_replay with `args` (standard input from `stdin_path` when given).
ToolRun run_tool(const std::vector<std::string>& args, const std::string& stdin_path = "") {
  const std::string out = temp_path("stdout"), err = temp_path("stderr");
  std::string cmd = shell_quote(ESTIMATION_REPLAY_EXE);
  for (const std::string& a : args) cmd += " " + shell_quote(a);
  cmd += " < " + shell_quote(stdin_path.empty() ? "/dev/null" : stdin_path);
  cmd += " > " + shell_quote(out) + " 2> " + shell_quote(err);
  const int rc = std::system(cmd.c_str());
  ToolRun r;
  r.status = rc != -1 && WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  std::remove(out.c_str());
  std::remove(err.c_str());
  return r;
}

// Output columns (kOutputHeader).
enum Col { kT, kQw, kQx, kQy, kQz, kRoll, kPitch, kYaw, kBgx, kBgy, kBgz, kPx, kPy, kPz, kVx, kVy, kVz, kCols };
using OutRow = std::array<double, kCols>;

// The tool's CSV output, empty cells as NaN; checks the header and the column count of every row.
std::vector<OutRow> parse_output(const std::string& csv) {
  std::istringstream in(csv);
  std::string line;
  std::vector<OutRow> rows;
  if (!std::getline(in, line)) {
    ADD_FAILURE() << "no output";
    return rows;
  }
  EXPECT_EQ(line, quad::replay::kOutputHeader);
  while (std::getline(in, line)) {
    OutRow r;
    size_t n = 0, start = 0;
    for (;;) {
      const size_t end = line.find(',', start);
      const std::string cell = line.substr(start, end == std::string::npos ? std::string::npos : end - start);
      if (n < r.size()) r[n] = cell.empty() ? NAN : std::stod(cell);
      ++n;
      if (end == std::string::npos) break;
      start = end + 1;
    }
    EXPECT_EQ(n, static_cast<size_t>(kCols)) << line;
    rows.push_back(r);
  }
  return rows;
}

// The text of output columns [first, last] of every row: equal text means bit-identical estimates.
std::string columns_text(const std::string& csv, int first, int last) {
  std::istringstream in(csv);
  std::string line, text;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    for (int c = 0; std::getline(ss, cell, ','); ++c) {
      if (c >= first && c <= last) text += cell + ",";
    }
    text += "\n";
  }
  return text;
}

double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// Synthetic logs written to a file: a level vehicle (yawing at a constant rate about the vertical),
// moving at a constant NED velocity, so that its specific force is exactly (0, 0, -g) and the truth is
// known in closed form. Options add sensor errors, disturbances and delayed, noisy vision fixes.
struct LogSpec {
  double rate_hz = 100.0, duration_s = 20.0;
  double yaw_rate = 0.0;                                   // rad/s, about NED down
  Eigen::Vector3d p0{0.0, 0.0, -1.5}, velocity{0.0, 0.0, 0.0};  // NED, m and m/s
  Eigen::Vector3d gyro_bias{0.0, 0.0, 0.0};                // rad/s, FRD
  double accel_z_bias = 0.0;                               // m/s^2 added to az
  double gyro_noise = 0.0, accel_noise = 0.0, mag_noise = 0.0;  // per-sample standard deviations
  // Magnetometer disturbance: the measured field turned by mag_turn_deg about body z on rows [first, end).
  double mag_turn_deg = 0.0;
  int mag_turn_first = 0, mag_turn_end = 0;
  // Manoeuvre: the specific force scaled by accel_scale and tilted by accel_tilt_deg about body y on rows
  // [first, end) (the vehicle accelerating; the attitude does not change).
  double accel_scale = 1.0, accel_tilt_deg = 0.0;
  int accel_first = 0, accel_end = 0;
  // Vision fixes: one every fix_every rows (0: none), delivered fix_delay_rows rows after capture.
  int fix_every = 0, fix_delay_rows = 6;
  double fix_noise = 0.0;
  int outlier_fix = -1;  // index of a fix moved by outlier_offset
  Eigen::Vector3d outlier_offset{0.0, 0.0, 0.0};
  unsigned seed = 7;
  // Truth.
  double t(int k) const { return k / rate_hz; }
  double yaw(int k) const { return yaw_rate * t(k); }
  Eigen::Vector3d p(int k) const { return p0 + velocity * t(k); }
  int rows() const { return static_cast<int>(std::lround(duration_s * rate_hz)) + 1; }
};

const Eigen::Vector3d kField(0.2, 0.0, 0.45);  // NED, gauss: the example's field

std::string write_log(const LogSpec& s, const std::string& stem) {
  std::mt19937 rng(s.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto noise = [&](double sd) { return Eigen::Vector3d(sd * n01(rng), sd * n01(rng), sd * n01(rng)); };
  const double g = 9.80665;
  struct Fix {
    int deliver;
    double t;
    Eigen::Vector3d p;
  };
  std::vector<Fix> fixes;
  std::ostringstream log;
  log.precision(9);
  log << kHeader;
  for (int k = 0; k < s.rows(); ++k) {
    const Eigen::Matrix3d r_ib = Eigen::AngleAxisd(s.yaw(k), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d gyro = Eigen::Vector3d(0.0, 0.0, s.yaw_rate) + s.gyro_bias + noise(s.gyro_noise);
    Eigen::Vector3d accel(0.0, 0.0, -g);
    if (k >= s.accel_first && k < s.accel_end) {
      accel = s.accel_scale * (Eigen::AngleAxisd(s.accel_tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()) * accel);
    }
    accel += Eigen::Vector3d(0.0, 0.0, s.accel_z_bias) + noise(s.accel_noise);
    Eigen::Vector3d mag = r_ib.transpose() * kField;
    if (k >= s.mag_turn_first && k < s.mag_turn_end) {
      mag = Eigen::AngleAxisd(s.mag_turn_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * mag;
    }
    mag += noise(s.mag_noise);
    if (s.fix_every > 0 && k % s.fix_every == 0) {
      Eigen::Vector3d p = s.p(k) + noise(s.fix_noise);
      if (static_cast<int>(fixes.size()) == s.outlier_fix) p += s.outlier_offset;
      fixes.push_back({k + s.fix_delay_rows, s.t(k), p});
    }
    log << s.t(k) << "," << gyro.x() << "," << gyro.y() << "," << gyro.z() << "," << accel.x() << "," << accel.y()
        << "," << accel.z() << "," << mag.x() << "," << mag.y() << "," << mag.z();
    const auto due = std::find_if(fixes.begin(), fixes.end(), [&](const Fix& f) { return f.deliver == k; });
    if (due != fixes.end()) {
      log << "," << due->t << "," << due->p.x() << "," << due->p.y() << "," << due->p.z() << "\n";
    } else {
      log << ",,,,\n";
    }
  }
  const std::string path = temp_path(stem);
  std::ofstream(path) << log.str();
  temp_files().paths.push_back(path);
  return path;
}

// Runs the tool on `log` with `args`; expects exit status 0 and returns the parsed output.
std::vector<OutRow> estimates(const std::string& log, std::vector<std::string> args, ToolRun* run = nullptr) {
  args.push_back(log);
  ToolRun r = run_tool(args);
  EXPECT_EQ(r.status, 0) << r.err;
  auto rows = parse_output(r.out);
  if (run) *run = std::move(r);
  return rows;
}

double max_abs(const std::vector<OutRow>& rows, Col c, int from = 0) {
  double m = 0.0;
  for (size_t k = static_cast<size_t>(from); k < rows.size(); ++k) m = std::max(m, std::abs(rows[k][c]));
  return m;
}

// Total attitude error angle against a level vehicle at the truth heading, rad.
double attitude_error(const OutRow& r, double yaw_true) {
  const Eigen::Quaterniond q(r[kQw], r[kQx], r[kQy], r[kQz]);
  return Eigen::AngleAxisd(Eigen::AngleAxisd(yaw_true, Eigen::Vector3d::UnitZ()).inverse() * q.normalized()).angle();
}

// Position RMS per axis against the truth over rows [from, end).
Eigen::Vector3d position_rms(const std::vector<OutRow>& rows, const LogSpec& s, int from) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (int k = from; k < static_cast<int>(rows.size()); ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d(rows[k][kPx], rows[k][kPy], rows[k][kPz]) - s.p(k);
    sum += e.cwiseProduct(e);
    ++n;
  }
  return (sum / n).cwiseSqrt();
}

TEST(ReplayTool, FilterChoiceSelectsTheFilter) {
  // At rest, level, heading north; the measured field turned by 30 deg about the vertical for 5 s. Only
  // the unconditioned observer (eq. 4.4) lets the magnetometer tilt the estimate (docs/estimation.md:
  // 1.8 deg with table 8.1); the conditioned one (eq. 4.9) only turns the heading.
  LogSpec s;
  s.mag_turn_deg = 30.0;
  s.mag_turn_first = 500;
  s.mag_turn_end = 1000;
  const std::string log = write_log(s, "mag_disturbance.csv");
  ToolRun def, cond, uncond, mahony, linear;
  const auto r_def = estimates(log, {}, &def);
  const auto r_cond = estimates(log, {"--filter", "conditioned"}, &cond);
  const auto r_uncond = estimates(log, {"--filter", "unconditioned"}, &uncond);
  const auto r_mahony = estimates(log, {"--filter", "mahony"}, &mahony);
  const auto r_linear = estimates(log, {"--filter=linear"}, &linear);
  ASSERT_EQ(r_def.size(), static_cast<size_t>(s.rows()));
  EXPECT_EQ(def.out, cond.out);  // conditioned is the default
  const double tilt_cond = std::max(max_abs(r_cond, kRoll), max_abs(r_cond, kPitch)) * 180 / M_PI;
  const double tilt_uncond = std::max(max_abs(r_uncond, kRoll), max_abs(r_uncond, kPitch)) * 180 / M_PI;
  const double yaw_cond = max_abs(r_cond, kYaw) * 180 / M_PI;
  std::cout << "[figure] replay tool, field turned 30 deg for 5 s: roll/pitch moved " << tilt_cond
            << " deg (conditioned), " << tilt_uncond << " deg (unconditioned); conditioned yaw moved " << yaw_cond
            << " deg\n";
  EXPECT_LT(tilt_cond, 0.01);
  EXPECT_GT(tilt_uncond, 0.5);
  EXPECT_GT(yaw_cond, 5.0);  // the magnetometer is used, for the heading only
  // The four filters give four different attitude tracks.
  const std::vector<const std::string*> outs = {&cond.out, &uncond.out, &mahony.out, &linear.out};
  for (size_t i = 0; i < outs.size(); ++i) {
    for (size_t j = i + 1; j < outs.size(); ++j) {
      EXPECT_NE(columns_text(*outs[i], kQw, kYaw), columns_text(*outs[j], kQw, kYaw)) << i << " vs " << j;
    }
  }
  // The linear complementary filter has no bias estimate; the others have one.
  EXPECT_EQ(max_abs(r_linear, kBgx) + max_abs(r_linear, kBgy) + max_abs(r_linear, kBgz), 0.0);
  EXPECT_GT(max_abs(r_mahony, kBgz), 0.0);
  EXPECT_GT(max_abs(r_uncond, kBgz), 0.0);
  // The observer's health line only for the observer.
  EXPECT_NE(cond.err.find("; observer:"), std::string::npos) << cond.err;
  EXPECT_NE(uncond.err.find("; observer:"), std::string::npos) << uncond.err;
  EXPECT_EQ(mahony.err.find("; observer:"), std::string::npos) << mahony.err;
  EXPECT_EQ(linear.err.find("; observer:"), std::string::npos) << linear.err;
}

TEST(ReplayTool, BadNamesAndValuesStopWithStatus2) {
  const std::string log = write_log(LogSpec{}, "still.csv");
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--filter", "kalman", log}, "estimation_replay: --filter: unknown filter 'kalman'"},
      {{"--filter", "Mahony", log}, "--filter: unknown filter 'Mahony'"},
      {{"--propagator", "rk4", log}, "--propagator: unknown propagator 'rk4'"},
      {{"--noise-model", "pink", log}, "--noise-model: unknown noise model 'pink'"},
      {{"--k1", "abc", log}, "--k1: not a number: 'abc'"},
      {{"--gate=", log}, "--gate: not a number: ''"},
      {{"--tau", "inf", log}, "--tau: not a number: 'inf'"},
      {{"--mag-ref", "0.2,0", log}, "--mag-ref: expected three comma-separated numbers, got '0.2,0'"},
      {{"--mag-ref", "0.2,0,0.45,1", log}, "--mag-ref: expected three comma-separated numbers"},
      {{"--bogus", log}, "unknown option '--bogus'"},
      {{log, "--gate"}, "--gate needs a value"},
      {{log, log}, "more than one input file"},
      {{}, "no input log"},
  };
  for (const Case& c : cases) {
    const ToolRun r = run_tool(c.args);
    std::string joined;
    for (const auto& a : c.args) joined += a + " ";
    EXPECT_EQ(r.status, 2) << joined;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << joined << "\n" << r.err;
    EXPECT_NE(r.err.find("--help"), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "") << joined;  // nothing written before the options are known to be good
  }
  const ToolRun missing = run_tool({"/nonexistent/log.csv"});
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.err.find("cannot open '/nonexistent/log.csv'"), std::string::npos) << missing.err;
}

TEST(ReplayTool, PropagatorExactIntegratesAFastTurnExactly) {
  // Gyro only (all four observer gains zero): 10 Hz rows, a 5 rad/s turn, x = T|w|/2 = 0.25. The exact
  // exponential (eq. 4.14) integrates a constant rate exactly; the second-order terms over-turn by about
  // 2 x^5/30 = 6.5e-5 rad a step (tan of the half angle, after renormalisation), 6.5e-3 rad over 100 steps.
  LogSpec s;
  s.rate_hz = 10.0;
  s.duration_s = 10.0;
  s.yaw_rate = 5.0;
  const std::string log = write_log(s, "fast_turn.csv");
  const std::vector<std::string> gyro_only = {"--k1", "0", "--k2", "0", "--k3", "0", "--k4", "0"};
  auto with = [&](std::vector<std::string> a) {
    a.insert(a.begin(), gyro_only.begin(), gyro_only.end());
    return a;
  };
  ToolRun def, second;
  const auto r_exact = estimates(log, with({"--propagator", "exact"}));
  const auto r_second = estimates(log, with({"--propagator", "second-order"}), &second);
  estimates(log, gyro_only, &def);
  EXPECT_EQ(def.out, second.out);  // second order is the default
  ASSERT_EQ(r_exact.size(), 101u);
  double worst_exact = 0.0;
  for (int k = 0; k <= 100; ++k) worst_exact = std::max(worst_exact, std::abs(wrap(r_exact[k][kYaw] - s.yaw(k))));
  const double end_second = wrap(r_second[100][kYaw] - s.yaw(100));
  std::cout << "[figure] replay tool, gyro only, 5 rad/s at 10 Hz for 10 s: yaw error exact " << worst_exact
            << " rad (worst), second order " << end_second << " rad (end)\n";
  EXPECT_LT(worst_exact, 1e-4);
  EXPECT_GT(end_second, 3e-3);
  EXPECT_LT(end_second, 1.3e-2);
  EXPECT_LT(max_abs(r_exact, kRoll) + max_abs(r_exact, kPitch) + max_abs(r_second, kRoll) + max_abs(r_second, kPitch),
            1e-5);
}

TEST(ReplayTool, ObserverGainsSetTheBiasEstimate) {
  // At rest with a gyro bias of 0.02 rad/s per axis for 30 s (docs/estimation.md, "Gyro bias").
  LogSpec s;
  s.duration_s = 30.0;
  s.gyro_bias = Eigen::Vector3d(0.02, 0.02, 0.02);
  const std::string log = write_log(s, "gyro_bias.csv");
  const auto bias = [](const OutRow& r) { return Eigen::Vector3d(r[kBgx], r[kBgy], r[kBgz]); };
  const std::vector<std::string> fast = {"--k1", "2", "--k2", "2", "--k3", "0.4", "--k4", "0.4", "--delta", "0.05"};
  auto with = [&](std::vector<std::string> a) {
    a.insert(a.begin(), fast.begin(), fast.end());
    return a;
  };
  const Eigen::Vector3d b_table = bias(estimates(log, {}).back());
  const Eigen::Vector3d b_fast = bias(estimates(log, fast).back());
  // Delta = 0.02 is below the true norm 0.035: kb pulls the estimate back to the ball; kb = 0 does not.
  const Eigen::Vector3d b_pulled = bias(estimates(log, with({"--delta", "0.02", "--kb", "16"})).back());
  const Eigen::Vector3d b_free = bias(estimates(log, with({"--delta", "0.02", "--kb", "0"})).back());
  std::cout << "[figure] replay tool, gyro bias 0.02 rad/s, 30 s: table 8.1 " << b_table.transpose() << ", fast gains "
            << b_fast.transpose() << "; Delta 0.02: norm " << b_pulled.norm() << " (kb 16), " << b_free.norm()
            << " (kb 0)\n";
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(b_fast[i], 0.02, 0.002) << i;
    EXPECT_GT(std::abs(b_table[i] - 0.02), 0.002) << i;  // table 8.1's bias mode is ~30 s slow
    EXPECT_NEAR(b_free[i], 0.02, 0.002) << i;
  }
  EXPECT_LT(b_pulled.norm(), 0.025);

  // The unconditioned observer's integral gain.
  const auto r_uncond = estimates(log, {"--filter", "unconditioned"});
  const auto r_uncond_ki0 = estimates(log, {"--filter", "unconditioned", "--ki", "0"});
  EXPECT_EQ(max_abs(r_uncond_ki0, kBgx) + max_abs(r_uncond_ki0, kBgy) + max_abs(r_uncond_ki0, kBgz), 0.0);
  for (int i = 0; i < 3; ++i) EXPECT_GT(bias(r_uncond.back())[i], 0.004) << i;

  // Mahony without its integral term: no bias estimate, a steady attitude error |b| / kp.
  const auto r_p1 = estimates(log, {"--filter", "mahony", "--mahony-ki", "0", "--kp", "1"});
  const auto r_p4 = estimates(log, {"--filter", "mahony", "--mahony-ki", "0", "--kp", "4"});
  const auto r_mahony = estimates(log, {"--filter", "mahony"});
  EXPECT_EQ(max_abs(r_p1, kBgx) + max_abs(r_p1, kBgy) + max_abs(r_p1, kBgz), 0.0);
  EXPECT_GT(bias(r_mahony.back()).minCoeff(), 0.004);
  const double e1 = attitude_error(r_p1.back(), 0.0), e4 = attitude_error(r_p4.back(), 0.0);
  EXPECT_NEAR(e1, s.gyro_bias.norm() / 1.0, 0.15 * s.gyro_bias.norm());
  EXPECT_NEAR(e4, s.gyro_bias.norm() / 4.0, 0.15 * s.gyro_bias.norm() / 4.0);

  // Linear complementary filter: no bias estimate, a steady error tau b per Euler angle.
  for (double tau : {1.0, 0.25}) {
    const auto r = estimates(log, {"--filter", "linear", "--tau", std::to_string(tau)});
    EXPECT_NEAR(r.back()[kRoll], tau * 0.02, 0.1 * tau * 0.02) << tau;
    EXPECT_NEAR(r.back()[kPitch], tau * 0.02, 0.1 * tau * 0.02) << tau;
  }
}

TEST(ReplayTool, AccelToleranceDecidesWhenTheAccelerometerIsUsed) {
  // A 1 s manoeuvre at 1.3 g, tilted 10 deg: outside the default tolerance 0.2, inside 0.5.
  LogSpec s;
  s.duration_s = 5.0;
  s.accel_scale = 1.3;
  s.accel_tilt_deg = 10.0;
  s.accel_first = 200;
  s.accel_end = 300;
  const std::string log = write_log(s, "manoeuvre.csv");
  for (const std::string filter : {"conditioned", "mahony", "linear"}) {
    ToolRun def, wide;
    const auto r_def = estimates(log, {"--filter", filter}, &def);
    const auto r_wide = estimates(log, {"--filter", filter, "--accel-tolerance", "0.5"}, &wide);
    EXPECT_LT(max_abs(r_def, kPitch), 1e-5) << filter;    // the manoeuvre is not taken for gravity
    EXPECT_GT(max_abs(r_wide, kPitch), 0.5 * M_PI / 180) << filter;  // now it is
    if (filter == "conditioned") {
      EXPECT_NE(def.err.find(" 100 accelerometer "), std::string::npos) << def.err;
      EXPECT_NE(wide.err.find(" 0 accelerometer "), std::string::npos) << wide.err;
    }
  }
}

TEST(ReplayTool, MagRefSetsTheHeadingReference) {
  // The README example reads the field along body x. Without --mag-ref that is magnetic north (yaw 0);
  // with an Earth field pointing east, the nose points east: yaw +90 deg.
  const std::string example = QUAD_SOURCE_DIR "/tools/estimation_replay/example/hover.csv";
  for (const std::string filter : {"conditioned", "mahony", "linear"}) {
    const auto north = estimates(example, {"--filter", filter});
    const auto east = estimates(example, {"--filter", filter, "--mag-ref", "0,0.2,0.45"});
    ASSERT_EQ(east.size(), 11u);
    for (size_t k = 0; k < east.size(); ++k) {
      EXPECT_NEAR(north[k][kYaw], 0.0, 0.5 * M_PI / 180) << filter << " row " << k;
      EXPECT_NEAR(east[k][kYaw], M_PI / 2, 0.5 * M_PI / 180) << filter << " row " << k;
      EXPECT_NEAR(east[k][kRoll], north[k][kRoll], 1e-4) << filter << " row " << k;
    }
  }
}

TEST(ReplayTool, PositionFilterOptions) {
  // Constant velocity, level: fixes at 25 Hz, 60 ms late, 2 cm noise; RMS over the last 15 s.
  LogSpec s;
  s.velocity = Eigen::Vector3d(0.5, -0.3, 0.1);
  s.fix_every = 4;
  s.fix_noise = 0.02;
  const std::string log = write_log(s, "moving.csv");
  ToolRun def_run;
  const auto def = estimates(log, {}, &def_run);
  const std::string def_attitude = columns_text(def_run.out, kT, kBgz);
  auto rms = [&](const std::vector<OutRow>& r) { return position_rms(r, s, 500); };
  auto run = [&](const std::vector<std::string>& args) {
    ToolRun tr;
    auto r = estimates(log, args, &tr);
    // Position options never touch the attitude.
    EXPECT_EQ(columns_text(tr.out, kT, kBgz), def_attitude) << args[0];
    return r;
  };
  const Eigen::Vector3d e_def = rms(def);
  const Eigen::Vector3d e_white = rms(run({"--noise-model", "white", "--q-accel", "0.01"}));
  const Eigen::Vector3d e_arrival = rms(run({"--noise-model", "white", "--q-accel", "0.01", "--fuse-on-arrival"}));
  const Eigen::Vector3d e_white_loose = rms(run({"--noise-model", "white", "--q-accel", "100"}));
  const Eigen::Vector3d e_thesis_small = rms(run({"--q-pos", "0.001", "--q-vel", "0.001"}));
  std::cout << "[figure] replay tool, 0.58 m/s, fixes 25 Hz 60 ms late 2 cm noise, position RMS (mm): thesis Q "
            << 1e3 * e_def.transpose() << "; white acceleration 0.01 " << 1e3 * e_white.transpose()
            << " (fused on arrival " << 1e3 * e_arrival.transpose() << "), 100 " << 1e3 * e_white_loose.transpose()
            << "; thesis Q 0.001 " << 1e3 * e_thesis_small.transpose() << "\n";
  // Fusing on arrival lags the vehicle by 60 ms of motion: 30 mm on x, 18 mm on y.
  EXPECT_GT(e_arrival.x(), 0.025);
  EXPECT_GT(e_arrival.x(), 2.0 * e_white.x());
  EXPECT_GT(e_arrival.y(), 1.5 * e_white.y());
  // Less process noise on a constant-velocity truth: smoother, closer to the truth.
  EXPECT_LT(e_white.norm(), 0.5 * e_def.norm());
  EXPECT_LT(e_white.norm(), 0.5 * e_white_loose.norm());
  EXPECT_LT(e_thesis_small.norm(), 0.7 * e_def.norm());

  // Per-axis options change their axes only.
  auto unchanged = [](const std::vector<OutRow>& a, const std::vector<OutRow>& b, std::vector<Col> cols) {
    double d = 0.0;
    for (size_t k = 0; k < a.size(); ++k) {
      for (Col c : cols) d = std::max(d, std::abs(a[k][c] - b[k][c]));
    }
    return d;
  };
  const auto sz = run({"--fix-sigma-z", "0.5"});
  const auto sxy = run({"--fix-sigma-xy", "0.5"});
  const auto zb = run({"--z-bias"});
  EXPECT_LT(unchanged(def, sz, {kPx, kPy, kVx, kVy}), 1e-6);
  EXPECT_GT(unchanged(def, sz, {kPz}), 1e-3);
  EXPECT_LT(unchanged(def, sxy, {kPz, kVz}), 1e-6);
  EXPECT_GT(unchanged(def, sxy, {kPx}), 1e-3);
  EXPECT_GT(unchanged(def, sxy, {kPy}), 1e-3);
  EXPECT_LT(unchanged(def, zb, {kPx, kPy, kVx, kVy}), 1e-6);
  EXPECT_GT(unchanged(def, zb, {kPz, kVz}), 1e-6);
}

// The truth of a LogSpec as the simulator's log.csv has it (the columns --truth reads).
std::string write_truth(const LogSpec& s, const std::string& stem) {
  std::ostringstream csv;
  csv.precision(9);
  csv << "t,true_n,true_e,true_d,true_roll,true_pitch,true_yaw\n";
  for (int k = 0; k < s.rows(); ++k) {
    const Eigen::Vector3d p = s.p(k);
    csv << s.t(k) << "," << p.x() << "," << p.y() << "," << p.z() << ",0,0," << wrap(s.yaw(k)) << "\n";
  }
  const std::string path = temp_path(stem);
  std::ofstream(path) << csv.str();
  temp_files().paths.push_back(path);
  return path;
}

TEST(ReplayTool, EkfFilterBesideTheThesisPairAndTheBaselinesAgainstTheTruth) {
  // Yawing slowly, moving at constant velocity, sensor noise and a gyro bias; fixes at 25 Hz, 60 ms late,
  // 5 mm noise. --filter ekf replays seed 004's EKF; --truth prints the error figures, --compare every
  // filter's on the same log.
  LogSpec s;
  s.yaw_rate = 0.05;
  s.velocity = Eigen::Vector3d(0.3, -0.2, 0.05);
  s.gyro_bias = Eigen::Vector3d(0.004, -0.003, 0.002);
  s.gyro_noise = 0.002;
  s.accel_noise = 0.03;
  s.mag_noise = 0.002;
  s.fix_every = 4;
  s.fix_noise = 0.005;
  const std::string log = write_log(s, "ekf.csv");
  const std::string truth = write_truth(s, "ekf_truth.csv");
  ToolRun run;
  const auto ekf = estimates(log, {"--filter", "ekf", "--truth", truth, "--from", "5"}, &run);
  ASSERT_EQ(static_cast<int>(ekf.size()), s.rows());
  const Eigen::Vector3d rms = position_rms(ekf, s, 500);
  std::cout << "[figure] replay --filter ekf, 0.36 m/s, fixes 25 Hz 60 ms late 5 mm noise, position RMS (mm) "
            << 1e3 * rms.transpose() << "\n" << run.err;
  EXPECT_LT(rms.norm(), 0.015);
  EXPECT_NE(run.err.find("; EKF: "), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("this filter"), std::string::npos) << run.err;
  // The figures the tool prints are the test's own: horizontal RMS over t >= 5 s.
  double h2 = 0.0;
  int n = 0;
  for (int k = 500; k < s.rows(); ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d(ekf[k][kPx], ekf[k][kPy], ekf[k][kPz]) - s.p(k);
    h2 += e.x() * e.x() + e.y() * e.y();
    ++n;
  }
  char expected[64];
  std::snprintf(expected, sizeof expected, "horizontal RMS %.1f mm", 1e3 * std::sqrt(h2 / n));
  EXPECT_NE(run.err.find(expected), std::string::npos) << expected << " in\n" << run.err;

  ToolRun all;
  estimates(log, {"--compare", "--truth", truth, "--from", "5"}, &all);
  std::cout << all.err;
  for (const char* name : {"thesis pair", "unconditioned", "mahony", "linear", "ekf"}) {
    EXPECT_NE(all.err.find(std::string("\n") + name), std::string::npos) << name << " in\n" << all.err;
  }
  // Usage errors: --compare without --truth, a truth file without its columns.
  EXPECT_EQ(run_tool({"--compare", log}).status, 2);
  const ToolRun bad_truth = run_tool({"--truth", log, log});
  EXPECT_EQ(bad_truth.status, 1);
  EXPECT_NE(bad_truth.err.find("column 'true_n' missing"), std::string::npos) << bad_truth.err;
}

TEST(ReplayTool, GateRejectsAnOutlierUnlessOpened) {
  LogSpec s;
  s.fix_every = 4;
  s.fix_noise = 0.02;
  s.outlier_fix = 200;  // at 8 s
  s.outlier_offset = Eigen::Vector3d(3.0, 0.0, 0.0);
  const std::string log = write_log(s, "outlier.csv");
  ToolRun def, open;
  const auto r_def = estimates(log, {}, &def);
  const auto r_open = estimates(log, {"--gate", "1000"}, &open);
  EXPECT_NE(def.err.find(" 1 outliers"), std::string::npos) << def.err;
  EXPECT_NE(open.err.find(" 0 outliers"), std::string::npos) << open.err;
  EXPECT_LT(max_abs(r_def, kPx, 100), 0.1);   // the track ignores it
  EXPECT_GT(max_abs(r_open, kPx, 100), 1.0);  // through an open gate it pulls the estimate metres away
}

TEST(ReplayTool, ZBiasStateRemovesTheHeightError) {
  // An accelerometer z bias of 0.3 m/s^2, fixes at 10 Hz, little process noise (docs/estimation.md).
  LogSpec s;
  s.duration_s = 40.0;
  s.accel_z_bias = 0.3;
  s.fix_every = 10;
  s.fix_noise = 0.01;
  const std::string log = write_log(s, "z_bias.csv");
  const std::vector<std::string> base = {"--noise-model", "white", "--q-accel", "0.01"};
  const double without = position_rms(estimates(log, base), s, 1000).z();
  auto with_args = base;
  with_args.push_back("--z-bias");
  const double with = position_rms(estimates(log, with_args), s, 1000).z();
  std::cout << "[figure] replay tool, z accelerometer bias 0.3 m/s^2: height RMS " << 1e3 * without
            << " mm without --z-bias, " << 1e3 * with << " mm with it\n";
  EXPECT_LT(with, 0.3 * without);
}

TEST(ReplayTool, EveryOptionIsAcceptedAndChangesItsPartOfTheOutput) {
  // A noisy, turning, moving log with a gyro bias and delayed fixes: each option against the same run
  // without it. Attitude options must change the attitude columns; position options must change the
  // position columns and leave the attitude columns bit-identical.
  LogSpec s;
  s.yaw_rate = 0.2;
  s.velocity = Eigen::Vector3d(0.3, 0.2, -0.1);
  s.gyro_bias = Eigen::Vector3d(0.02, -0.02, 0.02);
  s.gyro_noise = 0.002;
  s.accel_noise = 0.3;
  s.mag_noise = 0.002;
  s.fix_every = 4;
  s.fix_noise = 0.02;
  const std::string log = write_log(s, "everything.csv");
  struct Case {
    std::vector<std::string> base, option;
    bool attitude;
  };
  const std::vector<Case> cases = {
      {{}, {"--propagator", "exact"}, true},
      {{}, {"--k1", "2"}, true},
      {{}, {"--k2", "1"}, true},
      {{}, {"--k3", "0.3"}, true},
      {{}, {"--k4", "0.1"}, true},
      {{"--delta", "0.005"}, {"--kb", "1"}, true},
      {{}, {"--delta", "0.005"}, true},
      {{"--filter", "unconditioned"}, {"--ki", "0.3"}, true},
      {{"--filter", "mahony"}, {"--kp", "3"}, true},
      {{"--filter", "mahony"}, {"--mahony-ki", "0.3"}, true},
      {{"--filter", "linear"}, {"--tau", "0.3"}, true},
      {{}, {"--accel-tolerance", "0.01"}, true},
      {{}, {"--mag-ref", "0,0.2,0.45"}, true},
      {{}, {"--noise-model", "white"}, false},
      {{}, {"--q-pos", "0.1"}, false},
      {{}, {"--q-vel", "0.1"}, false},
      {{"--noise-model", "white"}, {"--q-accel", "0.1"}, false},
      {{}, {"--fix-sigma-xy", "0.1"}, false},
      {{}, {"--fix-sigma-z", "0.1"}, false},
      {{}, {"--gate", "0.5"}, false},
      {{}, {"--z-bias"}, false},
      {{}, {"--fuse-on-arrival"}, false},
      {{"--filter", "ekf"}, {"--star", "0.1,0,0"}, true},
  };
  for (const Case& c : cases) {
    auto args = c.base;
    args.push_back(log);
    const ToolRun ref = run_tool(args);
    args = c.base;
    args.insert(args.end(), c.option.begin(), c.option.end());
    args.push_back(log);
    const ToolRun r = run_tool(args);
    const std::string name = c.option[0];
    ASSERT_EQ(r.status, 0) << name << ": " << r.err;
    ASSERT_EQ(ref.status, 0) << name << ": " << ref.err;
    const std::string att_ref = columns_text(ref.out, kQw, kBgz), att = columns_text(r.out, kQw, kBgz);
    const std::string pos_ref = columns_text(ref.out, kPx, kVz), pos = columns_text(r.out, kPx, kVz);
    if (c.attitude) {
      EXPECT_NE(att, att_ref) << name << " did not change the attitude";
    } else {
      EXPECT_EQ(att, att_ref) << name << " changed the attitude";
      EXPECT_NE(pos, pos_ref) << name << " did not change the position";
    }
  }
}

TEST(ReplayTool, OutputFileStandardInputInlineValuesAndHelp) {
  const std::string example = QUAD_SOURCE_DIR "/tools/estimation_replay/example/hover.csv";
  const ToolRun to_stdout = run_tool({example});
  ASSERT_EQ(to_stdout.status, 0) << to_stdout.err;
  // -o FILE writes the same bytes as standard output, and nothing to standard output.
  const std::string file = temp_path("estimates.csv");
  const ToolRun to_file = run_tool({example, "-o", file});
  EXPECT_EQ(to_file.status, 0) << to_file.err;
  EXPECT_EQ(to_file.out, "");
  EXPECT_EQ(slurp(file), to_stdout.out);
  std::remove(file.c_str());
  const ToolRun unwritable = run_tool({example, "-o", "/nonexistent/dir/out.csv"});
  EXPECT_EQ(unwritable.status, 1);
  EXPECT_NE(unwritable.err.find("cannot write"), std::string::npos) << unwritable.err;
  // "-" reads standard input; errors then name <stdin>.
  const ToolRun from_stdin = run_tool({"-"}, example);
  EXPECT_EQ(from_stdin.status, 0) << from_stdin.err;
  EXPECT_EQ(from_stdin.out, to_stdout.out);
  const ToolRun bad_stdin = run_tool({"-"}, QUAD_SOURCE_DIR "/tests/estimation/data/time_backwards.csv");
  EXPECT_EQ(bad_stdin.status, 1);
  EXPECT_NE(bad_stdin.err.find("<stdin>:4: column 't' (1): time goes backwards"), std::string::npos) << bad_stdin.err;
  // --option=value is --option value; the defaults spelled out change nothing.
  const ToolRun spaced = run_tool({"--k1", "2", "--fix-sigma-z", "0.08", example});
  const ToolRun inline_ = run_tool({"--k1=2", "--fix-sigma-z=0.08", example});
  EXPECT_EQ(spaced.status, 0);
  EXPECT_EQ(inline_.out, spaced.out);
  EXPECT_NE(spaced.out, to_stdout.out);
  const ToolRun defaults = run_tool({"--filter", "conditioned", "--propagator", "second-order", "--noise-model", "thesis",
                                     "--k1", "1", "--k2", "0.2", "--gate", "5", "--fix-sigma-xy", "0.05", example});
  EXPECT_EQ(defaults.out, to_stdout.out);
  // --help: exit 0, every option listed.
  const ToolRun help = run_tool({"--help"});
  EXPECT_EQ(help.status, 0);
  for (const char* option :
       {"-o FILE", "--filter", "--propagator", "--k1", "--k2", "--k3", "--k4", "--kb", "--delta", "--ki", "--kp",
        "--mahony-ki", "--tau", "--accel-tolerance", "--mag-ref", "--noise-model", "--q-pos", "--q-vel", "--q-accel",
        "--fix-sigma-xy", "--fix-sigma-z", "--gate", "--z-bias", "--fuse-on-arrival"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
  }
  EXPECT_EQ(run_tool({"-h"}).out, help.out);
}

// The README's example: the hand-written log in both READMEs is example/hover.csv byte for byte, and the
// tool runs on it as documented.

// The contents of the ```csv fenced blocks of a Markdown file.
std::vector<std::string> csv_blocks(const std::string& markdown) {
  std::vector<std::string> blocks;
  std::istringstream in(markdown);
  std::string line, block;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!inside && line == "```csv") {
      inside = true;
      block.clear();
    } else if (inside && line.rfind("```", 0) == 0) {
      inside = false;
      blocks.push_back(block);
    } else if (inside) {
      block += line + "\n";
    }
  }
  EXPECT_FALSE(inside) << "unterminated ```csv block";
  return blocks;
}

TEST(ReplayExample, ReadmeCsvBlocksAreTheExampleFile) {
  const std::string example = slurp(QUAD_SOURCE_DIR "/tools/estimation_replay/example/hover.csv");
  ASSERT_FALSE(example.empty());
  for (const char* readme : {QUAD_SOURCE_DIR "/README.md", QUAD_SOURCE_DIR "/tools/estimation_replay/README.md"}) {
    const auto blocks = csv_blocks(slurp(readme));
    ASSERT_EQ(blocks.size(), 1u) << readme;
    EXPECT_EQ(blocks[0], example) << readme << ": its ```csv block is not example/hover.csv";
  }
}

TEST(ReplayExample, RunsAsTheReadmeSays) {
  const std::string readme = slurp(QUAD_SOURCE_DIR "/README.md");
  const std::string example = QUAD_SOURCE_DIR "/tools/estimation_replay/example/hover.csv";
  // The README's command, and its documented output header.
  ASSERT_NE(readme.find("build/host/bin/estimation_replay tools/estimation_replay/example/hover.csv -o estimates.csv"),
            std::string::npos);
  const size_t h = readme.find("`t,qw,");
  ASSERT_NE(h, std::string::npos) << "README.md documents no output header";
  const std::string documented = readme.substr(h + 1, readme.find('`', h + 1) - h - 1);
  EXPECT_EQ(documented, quad::replay::kOutputHeader);

  const std::string file = temp_path("estimates.csv");
  const ToolRun r = run_tool({example, "-o", file});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string out = slurp(file);
  std::remove(file.c_str());
  EXPECT_EQ(out.substr(0, out.find('\n')), documented);
  EXPECT_NE(r.err.find("11 rows, 3 vision fixes: 2 fused, 0 outliers"), std::string::npos) << r.err;
  const auto rows = parse_output(out);
  ASSERT_EQ(rows.size(), 11u);
  const double deg = M_PI / 180;
  for (size_t k = 0; k < rows.size(); ++k) {
    const OutRow& row = rows[k];
    EXPECT_NEAR(row[kT], 0.01 * static_cast<double>(k), 1e-9);
    // Level and heading north (README: within 0.2 deg), unit quaternion, small bias.
    EXPECT_NEAR(std::hypot(std::hypot(row[kQw], row[kQx]), std::hypot(row[kQy], row[kQz])), 1.0, 1e-5) << k;
    EXPECT_LT(std::abs(row[kRoll]), 0.2 * deg) << k;
    EXPECT_LT(std::abs(row[kPitch]), 0.2 * deg) << k;
    EXPECT_LT(std::abs(row[kYaw]), 0.2 * deg) << k;
    EXPECT_LT(std::abs(row[kBgx]) + std::abs(row[kBgy]) + std::abs(row[kBgz]), 1e-3) << k;
    // Position empty until the first fix (row 0.04), then near the fixes (0.10, -0.05, -1.50) +- 1 cm.
    if (k < 4) {
      for (int c = kPx; c <= kVz; ++c) EXPECT_TRUE(std::isnan(row[c])) << k;
    } else {
      EXPECT_NEAR(row[kPx], 0.10, 0.012) << k;
      EXPECT_NEAR(row[kPy], -0.05, 0.012) << k;
      EXPECT_NEAR(row[kPz], -1.50, 0.012) << k;
      EXPECT_LT(std::hypot(std::hypot(row[kVx], row[kVy]), row[kVz]), 0.5) << k;
    }
  }
  // The last fix (0.10, -0.05, -1.49) pulls the estimate back from the second (0.11, -0.04, -1.51).
  EXPECT_NEAR(rows[10][kPz], -1.49, 0.002);
}

}  // namespace
