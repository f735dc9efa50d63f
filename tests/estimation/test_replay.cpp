// The replay tool's log reader (errors name line and column) and the whole replay chain on a synthetic
// log: attitude, kinematic acceleration, delayed vision fixes, CSV output.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <sstream>

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
  o.position.process_noise = quad::est::ProcessNoise::WhiteAcceleration;
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

}  // namespace
