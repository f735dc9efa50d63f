// The simulated vision fix (geometry of LANDING_TARGET in body FRD, rate, latency, noise) and the
// combination of overlapping faults.
#include <gtest/gtest.h>

#include <cmath>

#include "quad/link/mavlink.h"
#include "quad/sim/faults.h"
#include "quad/sim/frames.h"
#include "quad/sim/vision_fix.h"

namespace quad::sim {
namespace {

TEST(VisionFix, TheStarSeenFromTheVehicleInBodyFrd) {
  // Level, heading north, 1.5 m above the star: the star is straight below (+z in FRD).
  EXPECT_TRUE(star_in_body_frd({0, 0, -1.5}, Eigen::Quaterniond::Identity()).isApprox(Eigen::Vector3d(0, 0, 1.5)));
  // 1 m north of the star, heading north: the star is behind (-x).
  EXPECT_TRUE(star_in_body_frd({1, 0, -1.5}, Eigen::Quaterniond::Identity()).isApprox(Eigen::Vector3d(-1, 0, 1.5)));
  // 1 m north of the star, heading east (yaw +90 deg): the star is on the right (+y).
  EXPECT_TRUE(star_in_body_frd({1, 0, -1.5}, q_ib_from_yaw(M_PI / 2)).isApprox(Eigen::Vector3d(0, 1, 1.5), 1e-12));
  // The firmware's inverse (thesis eq. 8.5 with the errata sign) recovers the position for any attitude.
  for (int k = 0; k < 10; ++k) {
    const Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();
    const Eigen::Vector3d p(0.3 * k, -0.2, -1.0 - 0.1 * k);
    EXPECT_TRUE((-(q * star_in_body_frd(p, q))).isApprox(p, 1e-12));
  }
}

std::vector<std::pair<double, mavlink::LandingTarget>> run_fixes(const VisionParams& params, double seconds,
                                                                 double dropout_from = 1e9, double dropout_to = 1e9) {
  SimulatedVisionFix fix(params, Rng(5, "vision"));
  mavlink::Parser parser;
  std::vector<std::pair<double, mavlink::LandingTarget>> out;
  for (int k = 1; k <= static_cast<int>(seconds * 1000); ++k) {
    const double t = k * 1e-3;
    fix.update(t, {0.5, -0.25, -1.5}, Eigen::Quaterniond::Identity(), t >= dropout_from && t < dropout_to);
    fix.release_until(t, [&](double when, const uint8_t* d, size_t n) {
      parser.feed(d, n, [&](const mavlink::Frame& f) {
        mavlink::LandingTarget lt;
        if (mavlink::decode(f, lt)) out.emplace_back(when, lt);
      });
    });
  }
  return out;
}

TEST(VisionFix, RateLatencyAndNoise) {
  VisionParams p;
  p.rate_hz = 30.0;
  p.latency_s = 0.022;
  p.noise_m = 0.01;
  const auto fixes = run_fixes(p, 100.0);
  EXPECT_NEAR(static_cast<double>(fixes.size()), 3000.0, 1.0);
  double sum = 0.0, sum_sq = 0.0;
  for (const auto& [released, lt] : fixes) {
    EXPECT_EQ(lt.frame, mavlink::kFrameBodyFrd);
    EXPECT_EQ(lt.position_valid, 1);
    EXPECT_NEAR(released - static_cast<double>(lt.time_usec) * 1e-6, 0.022, 1e-3) << "released after the latency";
    const double e = -lt.x - 0.5;  // level, heading north: p_N = -x_B
    sum += e;
    sum_sq += e * e;
  }
  const double n = static_cast<double>(fixes.size());
  EXPECT_NEAR(sum / n, 0.0, 4.0 * 0.01 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(sum_sq / n), 0.01, 0.001);
}

TEST(VisionFix, NothingIsCapturedDuringADropoutOrWhenDisabled) {
  VisionParams p;
  const auto fixes = run_fixes(p, 3.0, 1.0, 2.0);
  for (const auto& [released, lt] : fixes) {
    const double captured = static_cast<double>(lt.time_usec) * 1e-6;
    EXPECT_TRUE(captured < 1.0 || captured >= 2.0) << captured;
  }
  EXPECT_NEAR(static_cast<double>(fixes.size()), 60.0, 2.0);
  p.enabled = false;
  EXPECT_TRUE(run_fixes(p, 1.0).empty());
}

TEST(Faults, OverlappingFaultsCombine) {
  std::vector<Fault> faults(6);
  faults[0] = {FaultType::kRadioLoss, 1.0, 3.0, 0.3, {}, 0};
  faults[1] = {FaultType::kRadioLoss, 2.0, 4.0, 0.8, {}, 0};
  faults[2] = {FaultType::kMagDisturbance, 0.0, 5.0, 0.0, {0.1, 0.0, 0.0}, 0};
  faults[3] = {FaultType::kMagDisturbance, 2.0, 5.0, 0.0, {0.0, 0.2, 0.0}, 0};
  faults[4] = {FaultType::kMotorEfficiency, 2.0, 5.0, 0.5, {}, 3};
  faults[5] = {FaultType::kMotorEfficiency, 2.5, 5.0, 0.5, {}, 3};
  RadioConditions base{0.004, 0.002, 0.01, 1e-6};
  const FaultEffects before = fault_effects(faults, base, 0.5);
  EXPECT_DOUBLE_EQ(before.radio.loss, 0.01);
  EXPECT_TRUE(before.mag_offset_ned_gauss.isApprox(Eigen::Vector3d(0.1, 0, 0)));
  const FaultEffects both = fault_effects(faults, base, 2.7);
  EXPECT_DOUBLE_EQ(both.radio.loss, 0.8) << "the worst loss";
  EXPECT_DOUBLE_EQ(both.radio.latency_s, 0.004) << "untouched conditions stay";
  EXPECT_TRUE(both.mag_offset_ned_gauss.isApprox(Eigen::Vector3d(0.1, 0.2, 0))) << "offsets add";
  EXPECT_DOUBLE_EQ(both.motor_efficiency[3], 0.25) << "efficiencies multiply";
  EXPECT_DOUBLE_EQ(both.motor_efficiency[0], 1.0);
  const FaultEffects after = fault_effects(faults, base, 5.0);
  EXPECT_DOUBLE_EQ(after.motor_efficiency[3], 1.0) << "end time is exclusive";
  EXPECT_FALSE(after.vision_dropout || after.rc_loss);
}

}  // namespace
}  // namespace quad::sim
