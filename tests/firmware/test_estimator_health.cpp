// The estimator's health report and pre-arm check in the flight application, through its MAVLink bytes:
// ESTIMATOR_STATUS (flags, test ratios, accuracies) for both estimators on the ground, before and after
// fixes, and the arm command refused with a STATUSTEXT that names the variance until it has settled.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <string>

#include "app_bench.h"
#include "quad/firmware/app.h"

namespace {

using quad::fw::Preflight;
using quad::fw::test::Bench;
using quad::fw::test::VerticalFlight;
namespace mav = quad::mavlink;

// Boots with EST_TYPE est_type and steps still until the boot calibration is done.
void boot_and_calibrate(Bench& b, float est_type) {
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kEstType, est_type), nullptr);
  b.sticks(0);
  for (int i = 0; i < 1000 && !b.app->calibrated(); ++i) b.still_step();
  ASSERT_TRUE(b.app->calibrated());
}

// Still steps until the pre-arm check passes; the number of steps taken (-1: never within 3 s).
int steps_until_ready(Bench& b) {
  for (int i = 0; i < 300; ++i) {
    if (b.app->estimator().preflight() == Preflight::kReady) return i;
    b.still_step();
  }
  return -1;
}

bool has(const mav::EstimatorStatus& s, uint16_t flag) { return (s.flags & flag) != 0; }

TEST(PreArm, ThesisPairWaitsForThePositionFiltersVariances) {
  Bench b;
  boot_and_calibrate(b, 0.0f);
  // Calibrated, but the position filter waits for the ground hold's still time (0.5 s).
  EXPECT_EQ(b.app->estimator().preflight(), Preflight::kPosition);
  EXPECT_EQ(b.arm(), mav::kResultDenied);
  EXPECT_TRUE(b.said("PREFLIGHT: estimator not converged: position var"));
  EXPECT_EQ(b.app->mode(), quad::fw::FlightMode::kDisarmed);
  const int steps = steps_until_ready(b);
  std::printf("[figure] thesis pair: ready to arm %d steps (10 ms) after the calibration\n", steps);
  ASSERT_GT(steps, 0);
  EXPECT_LE(steps, 60) << "the ground hold starts after 0.5 s still";
  b.sticks(0);
  EXPECT_EQ(b.arm(), mav::kResultAccepted);
  EXPECT_TRUE(b.said("MANUAL: armed"));
}

TEST(PreArm, EkfWaitsForItsAttitudeAndVelocityVariances) {
  Bench b;
  boot_and_calibrate(b, 1.0f);
  const Preflight first = b.app->estimator().preflight();
  EXPECT_TRUE(first == Preflight::kAttitude || first == Preflight::kVelocity) << static_cast<int>(first);
  EXPECT_EQ(b.arm(), mav::kResultDenied);
  EXPECT_TRUE(b.said(first == Preflight::kAttitude ? "PREFLIGHT: estimator not converged: attitude var"
                                                   : "PREFLIGHT: estimator not converged: velocity var"));
  const int steps = steps_until_ready(b);
  std::printf("[figure] EKF: ready to arm %d steps (10 ms) after the calibration\n", steps);
  ASSERT_GT(steps, 0);
  b.sticks(0);
  EXPECT_EQ(b.arm(), mav::kResultAccepted);
}

TEST(PreArm, ThesisPairArmsStandingInViewOfTheStar) {
  // Fixes of the standing vehicle keep the ground hold away; the fixes' position variance passes.
  Bench b;
  boot_and_calibrate(b, 0.0f);
  VerticalFlight flight(b);
  flight.fly_seconds(1.0f);
  EXPECT_EQ(b.app->estimator().preflight(), Preflight::kReady);
  b.sticks(0);
  EXPECT_EQ(b.arm(), mav::kResultAccepted);
}

TEST(PreArm, NotCalibratedSaysSo) {
  Bench b;
  b.boot();
  b.sticks(0);
  EXPECT_EQ(b.arm(), mav::kResultDenied);
  EXPECT_TRUE(b.said("PREFLIGHT: estimator not converged: calibrating"));
}

// On the ground without the star, then with fixes of the standing vehicle: the flags and ratios.
void check_health_report(float est_type) {
  Bench b;
  boot_and_calibrate(b, est_type);
  for (int i = 0; i < 150; ++i) b.still_step();  // 1.5 s: ESTIMATOR_STATUS at 2 Hz
  ASSERT_FALSE(b.estimator_statuses.empty());
  const mav::EstimatorStatus ground = b.estimator_statuses.back();
  EXPECT_TRUE(has(ground, mav::kEstimatorAttitude));
  EXPECT_TRUE(has(ground, mav::kEstimatorVelocityHoriz));
  EXPECT_TRUE(has(ground, mav::kEstimatorVelocityVert));
  EXPECT_TRUE(has(ground, mav::kEstimatorConstPosMode)) << "standing still without fixes";
  EXPECT_FALSE(has(ground, mav::kEstimatorPosHorizRel)) << "no fix yet";
  EXPECT_FALSE(has(ground, mav::kEstimatorPredPosHorizRel));
  EXPECT_FALSE(has(ground, mav::kEstimatorAccelError));
  // Fixes of the standing vehicle for 2 s.
  VerticalFlight flight(b);
  b.estimator_statuses.clear();
  flight.fly_seconds(2.0f);
  ASSERT_GE(b.estimator_statuses.size(), 3u);
  const mav::EstimatorStatus fixed = b.estimator_statuses.back();
  std::printf("[figure] EST_TYPE %.0f with fixes: flags 0x%03x, pos ratios %.3f %.3f, mag %.3f, vel %.3f, "
              "accuracy %.4f %.4f m\n",
              est_type, fixed.flags, fixed.pos_horiz_ratio, fixed.pos_vert_ratio, fixed.mag_ratio, fixed.vel_ratio,
              fixed.pos_horiz_accuracy, fixed.pos_vert_accuracy);
  EXPECT_TRUE(has(fixed, mav::kEstimatorAttitude));
  EXPECT_TRUE(has(fixed, mav::kEstimatorVelocityHoriz));
  EXPECT_TRUE(has(fixed, mav::kEstimatorVelocityVert));
  EXPECT_FALSE(has(fixed, mav::kEstimatorConstPosMode)) << "the fixes hold the estimate";
  EXPECT_TRUE(has(fixed, mav::kEstimatorPosHorizRel));
  EXPECT_TRUE(has(fixed, mav::kEstimatorPosVertAbs));
  EXPECT_TRUE(has(fixed, mav::kEstimatorPredPosHorizRel));
  EXPECT_LT(fixed.pos_horiz_ratio, 1.0f);
  EXPECT_LT(fixed.pos_vert_ratio, 1.0f);
  EXPECT_LT(fixed.mag_ratio, 1.0f);
  EXPECT_GT(fixed.pos_horiz_accuracy, 0.0f);
  EXPECT_LT(fixed.pos_horiz_accuracy, 0.3f);
  EXPECT_LT(fixed.pos_vert_accuracy, 0.3f);
  // The message's time is the vehicle's (the HIL clock), in order.
  for (size_t i = 1; i < b.estimator_statuses.size(); ++i)
    EXPECT_GT(b.estimator_statuses[i].time_usec, b.estimator_statuses[i - 1].time_usec);
}

TEST(EstimatorStatus, ThesisPairFlagsAndRatiosOnTheGroundAndWithFixes) { check_health_report(0.0f); }

TEST(EstimatorStatus, EkfFlagsAndRatiosOnTheGroundAndWithFixes) { check_health_report(1.0f); }

TEST(EstimatorStatus, SentAtTelEstHz) {
  Bench b;
  boot_and_calibrate(b, 0.0f);
  ASSERT_EQ(b.app->override_param(quad::fw::kTelEstHz, 5.0f), nullptr);
  b.estimator_statuses.clear();
  for (int i = 0; i < 200; ++i) b.still_step();  // 2 s
  EXPECT_NEAR(static_cast<double>(b.estimator_statuses.size()), 10.0, 1.0);
  ASSERT_EQ(b.app->override_param(quad::fw::kTelEstHz, 0.0f), nullptr);
  b.estimator_statuses.clear();
  for (int i = 0; i < 200; ++i) b.still_step();
  EXPECT_EQ(b.estimator_statuses.size(), 0u) << "0 turns the stream off";
}

}  // namespace
