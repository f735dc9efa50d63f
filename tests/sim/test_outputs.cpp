// Run outputs: the figures of summary.json (error statistics, settling, crash detection) and the
// writers (JSON, CSV flushed row by row).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "quad/sim/metrics.h"
#include "quad/sim/run_output.h"

namespace quad::sim {
namespace {

TEST(ErrorStats, AgreesWithTheDirectFormulas) {
  const double x[] = {0.3, -0.1, 0.25, 0.0, -0.4, 0.12};
  ErrorStats s;
  double sum = 0.0, sq = 0.0, max_abs = 0.0;
  for (double v : x) {
    s.add(v);
    sum += v;
    sq += v * v;
    max_abs = std::max(max_abs, std::abs(v));
  }
  const double n = 6.0, mean = sum / n;
  double var = 0.0;
  for (double v : x) var += (v - mean) * (v - mean);
  EXPECT_NEAR(s.mean(), mean, 1e-15);
  EXPECT_NEAR(s.stddev(), std::sqrt(var / (n - 1.0)), 1e-15);
  EXPECT_NEAR(s.rms(), std::sqrt(sq / n), 1e-15);
  EXPECT_DOUBLE_EQ(s.max_abs(), 0.4);
}

FlightMetricsConfig hold_10_to_30() {
  FlightMetricsConfig c;
  c.hold_start_s = 10.0;
  c.hold_end_s = 30.0;
  c.settle_band_m = 0.05;
  c.ground_down_m = -0.13;
  return c;
}

TEST(FlightMetrics, SettlingTimeOfAnExponentialApproach) {
  // Commanded at 2 s from 1 m away, the error decays with tau = 1 s: it enters the 5 cm band for good at
  // 2 + ln(20) s, i.e. 3.0 s after the command.
  FlightMetrics m(hold_10_to_30());
  const Eigen::Vector3d sp(0, 0, -1.5);
  for (int k = 200; k <= 4000; ++k) {
    const double t = k * 0.01;
    const Eigen::Vector3d p = sp + Eigen::Vector3d(std::exp(-(t - 2.0)), 0, 0);
    m.add(t, p, Eigen::Vector3d::Zero(), 0.0, sp, 2.0);
  }
  ASSERT_TRUE(m.settling_time_s().has_value());
  EXPECT_NEAR(*m.settling_time_s(), std::log(20.0), 0.011);
  EXPECT_EQ(m.hold(0).count(), 2001);  // 10.00 .. 30.00 s
  EXPECT_FALSE(m.crashed());
}

TEST(FlightMetrics, NoSettlingWhenTheHoldEndsOutsideTheBand) {
  FlightMetrics m(hold_10_to_30());
  const Eigen::Vector3d sp(0, 0, -1.5);
  for (int k = 0; k <= 4000; ++k) {
    const double t = k * 0.01;
    const double e = t > 29.0 && t < 30.5 ? 0.2 : 0.0;  // an excursion at the end of the hold
    m.add(t, sp + Eigen::Vector3d(0, e, 0), Eigen::Vector3d::Zero(), 0.0, sp, 0.0);
  }
  EXPECT_FALSE(m.settling_time_s().has_value());
  EXPECT_DOUBLE_EQ(m.hold(1).max_abs(), 0.2);
}

TEST(FlightMetrics, HorizontalStatistics) {
  FlightMetrics m(hold_10_to_30());
  const Eigen::Vector3d sp(0, 0, -1.5);
  for (int k = 1000; k <= 3000; ++k) {
    const double t = k * 0.01;
    const double a = 2.0 * M_PI * t;  // a 3 cm circle around a 1 cm north offset
    m.add(t, sp + Eigen::Vector3d(0.01 + 0.03 * std::cos(a), 0.03 * std::sin(a), 0), Eigen::Vector3d::Zero(), 0.0, sp, 0.0);
  }
  EXPECT_NEAR(m.hold(0).mean(), 0.01, 1e-4);
  EXPECT_NEAR(m.horizontal_stddev(), 0.03, 2e-4) << "sqrt(var_n + var_e) of a circle of radius r is r";
  EXPECT_NEAR(m.hold_horizontal().max_abs(), 0.04, 1e-4);
}

TEST(FlightMetrics, CrashOnTiltOrHardLanding) {
  FlightMetrics tilt(hold_10_to_30());
  tilt.add(1.0, {0, 0, -1}, Eigen::Vector3d::Zero(), 1.0, std::nullopt, 0.0);
  EXPECT_FALSE(tilt.crashed());
  tilt.add(1.01, {0, 0, -1}, Eigen::Vector3d::Zero(), 1.2, std::nullopt, 0.0);
  EXPECT_TRUE(tilt.crashed());
  EXPECT_DOUBLE_EQ(tilt.crash_time_s(), 1.01);

  FlightMetrics soft(hold_10_to_30()), hard(hold_10_to_30());
  soft.add(5.0, {0, 0, -0.13}, {0, 0, 0.5}, 0.0, std::nullopt, 0.0);  // touching down at 0.5 m/s
  hard.add(5.0, {0, 0, -0.13}, {0, 0, 3.0}, 0.0, std::nullopt, 0.0);  // at 3 m/s
  EXPECT_FALSE(soft.crashed());
  EXPECT_TRUE(hard.crashed());
  FlightMetrics fast_in_air(hold_10_to_30());
  fast_in_air.add(5.0, {0, 0, -2.0}, {0, 0, 3.0}, 0.0, std::nullopt, 0.0);
  EXPECT_FALSE(fast_in_air.crashed()) << "descending fast in the air is not a crash";
}

TEST(Json, NestedObjectsEscapingAndNonFiniteNumbers) {
  Json inner;
  inner.add("rms", 0.5).add("n", 3);
  Json j;
  j.add("name", "a \"quoted\"\nline").add("ok", true).add("inner", inner).add("nan", NAN);
  EXPECT_EQ(j.str(),
            "{\n  \"name\": \"a \\\"quoted\\\"\\nline\",\n  \"ok\": true,\n  \"inner\": {\n    \"rms\": 0.5,\n"
            "    \"n\": 3\n  },\n  \"nan\": null\n}");
}

TEST(CsvLog, EveryRowIsOnDiskAsSoonAsItIsWritten) {
  const std::string path = std::string(::testing::TempDir()) + "/quad_sim_csv_" + std::to_string(getpid()) + ".csv";
  CsvLog log(path, {"t", "x"});
  log.row({0.01, 1.5});
  std::ifstream in(path);  // read while the log is still open, as after a crash
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "t,x\n0.01,1.5\n");
  EXPECT_THROW(log.row({1.0}), std::logic_error);
}

}  // namespace
}  // namespace quad::sim
