// The ground hold in the flight application (docs/estimation.md, "Standing on the ground"): standing still
// and disarmed, the estimate stays where the vehicle stands for 30 s although the accelerometer's bias
// has drifted since the boot calibration; before any fix that is the ground's position (at the star,
// EST_GND_HGT above its floor), after fixes the last known one (once they have stopped for the history
// window and the still time).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <cstring>

#include "app_bench.h"
#include "quad/firmware/app.h"

namespace {

using quad::fw::test::Bench;
namespace mav = quad::mavlink;

void calibrate(Bench& b) {
  for (int i = 0; i < 1000 && !b.app->calibrated(); ++i) b.still_step();
  ASSERT_TRUE(b.app->calibrated());
}

// 30 s of standing still; the largest distance of the estimate from `where`.
float stand(Bench& b, const Eigen::Vector3f& where) {
  float worst = 0.0f;
  for (int i = 0; i < 3000; ++i) {
    b.still_step();
    const quad::Vec3 p = b.app->position();
    worst = std::max(worst, (Eigen::Vector3f(p.x, p.y, p.z) - where).norm());
  }
  return worst;
}

TEST(GroundHoldApp, BeforeAnyFixTheEstimateIsTheGroundsAndStaysThere) {
  Bench b;
  b.boot();
  set_param_echoed(b, "VIS_STAR_N", 1.0f);
  set_param_echoed(b, "VIS_STAR_E", -2.0f);
  set_param_echoed(b, "VIS_STAR_D", 0.3f);
  calibrate(b);
  // The accelerometer drifts after the calibration (0.5 deg of apparent tilt, 0.08 m/s^2 vertically).
  b.accel_bias += Eigen::Vector3f(0.085f, -0.05f, 0.08f);
  for (int i = 0; i < 60; ++i) b.still_step();  // the still time
  const Eigen::Vector3f ground(1.0f, -2.0f, 0.3f - 0.13f);  // EST_GND_HGT 0.13
  const float worst = stand(b, ground);
  std::printf("[figure] disarmed, no fix, 30 s: estimate within %.4f m of the ground's position\n", worst);
  EXPECT_LT(worst, 0.01f);
  EXPECT_TRUE(b.app->estimator().holding_ground());
}

TEST(GroundHoldApp, AfterTheFixesStopTheEstimateStaysAtTheLastKnownPosition) {
  Bench b;
  b.boot();
  calibrate(b);
  const Eigen::Vector3f p(0.3f, -0.2f, -0.13f);
  for (int i = 0; i < 200; ++i) {
    b.still_step();
    if (i >= 10 && i % 3 == 0) b.landing_target(p, Eigen::Quaternionf::Identity(), b.t_us - 40000);
  }
  ASSERT_GT(b.app->counters().fixes_fused, 50u);
  // The star out of view and the accelerometer drifted: the estimate dead-reckons until the last fix
  // has left the history window (0.25 s) and the still time (0.5 s) has passed, then holds.
  b.accel_bias += Eigen::Vector3f(0.085f, -0.05f, 0.08f);
  for (int i = 0; i < 80; ++i) b.still_step();
  ASSERT_TRUE(b.app->estimator().holding_ground());
  const quad::Vec3 held = b.app->position();
  const float worst = stand(b, Eigen::Vector3f(held.x, held.y, held.z));
  std::printf("[figure] disarmed, fixes stopped: %.4f m off after 0.8 s, then moved %.4f m in 30 s\n",
              (Eigen::Vector3f(held.x, held.y, held.z) - p).norm(), worst);
  EXPECT_LT(worst, 0.002f);
  EXPECT_LT((Eigen::Vector3f(held.x, held.y, held.z) - p).norm(), 0.04f);
}

}  // namespace
