// IMU clipping: the guard on its own (which axes count as clipped, the held rate, the time bound, the
// bursts) and inside the flight application (a clipped burst in AUTO leaves the estimate alone and is
// reported once; a clip longer than IMU_CLIP_HOLD lands through the estimator failsafe).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "app_bench.h"
#include "quad/firmware/imu_clip.h"
#include "quad/firmware/params.h"

namespace {

using quad::Vec3;
using quad::fw::FlightMode;
using quad::fw::ImuClipGuard;
using quad::fw::test::Bench;
namespace mav = quad::mavlink;

constexpr float kGyroRange = 2000.0f * 3.14159265f / 180.0f;  // MPU-6000 FS_SEL 3
constexpr float kAccelRange = 8.0f * 9.80665f;               // AFS_SEL 2
constexpr float kDt = 0.01f;

quad::hal::ImuSample sample(const Vec3& gyro, const Vec3& accel = Vec3{0.0f, 0.0f, -9.80665f}) {
  quad::hal::ImuSample s;
  s.gyro = gyro;
  s.accel = accel;
  return s;
}

ImuClipGuard guard() {
  ImuClipGuard g;
  g.configure(kGyroRange, kAccelRange, 0.05f);
  return g;
}

TEST(ImuClipGuard, DefaultRangesAreTheMpu6000Settings) {
  const quad::fw::Params p;
  EXPECT_NEAR(p.get(quad::fw::kImuGyroRange), kGyroRange, 1e-4f);
  EXPECT_NEAR(p.get(quad::fw::kImuAccRange), kAccelRange, 1e-4f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kImuClipHold), 0.05f);
}

TEST(ImuClipGuard, CleanSamplesPassUnchanged) {
  ImuClipGuard g = guard();
  // Just inside the limit on every axis, both signs: a hard manoeuvre, not a clip.
  const float fast = 0.985f * kGyroRange;
  const Vec3 out = g.update(sample(Vec3{fast, -fast, 0.3f}, Vec3{0.985f * kAccelRange, -1.0f, -9.8f}), kDt);
  EXPECT_FLOAT_EQ(out.x, fast);
  EXPECT_FLOAT_EQ(out.y, -fast);
  EXPECT_FLOAT_EQ(out.z, 0.3f);
  EXPECT_FALSE(g.gyro_clipped());
  EXPECT_FALSE(g.accel_clipped());
  EXPECT_TRUE(g.healthy());
  EXPECT_EQ(g.clipped_samples(), 0u);
}

TEST(ImuClipGuard, HoldsOnlyTheClippedAxesAtTheirLastGoodValue) {
  ImuClipGuard g = guard();
  g.update(sample(Vec3{0.1f, -0.2f, 0.05f}), kDt);
  g.update(sample(Vec3{0.12f, -0.25f, 0.04f}), kDt);
  // y pinned at the negative end, x at the positive end; z still good.
  const Vec3 out = g.update(sample(Vec3{kGyroRange, -kGyroRange, 0.07f}), kDt);
  EXPECT_FLOAT_EQ(out.x, 0.12f);
  EXPECT_FLOAT_EQ(out.y, -0.25f);
  EXPECT_FLOAT_EQ(out.z, 0.07f);
  EXPECT_TRUE(g.gyro_clipped());
  EXPECT_FALSE(g.accel_clipped());
  EXPECT_TRUE(g.healthy());
}

TEST(ImuClipGuard, AClippedAccelerometerIsFlaggedOnAnyAxis) {
  for (int axis = 0; axis < 3; ++axis) {
    for (float sign : {1.0f, -1.0f}) {
      ImuClipGuard g = guard();
      Vec3 a{0.0f, 0.0f, -9.8f};
      a[axis] = sign * kAccelRange;
      const Vec3 out = g.update(sample(Vec3{0.1f, 0.2f, 0.3f}, a), kDt);
      EXPECT_TRUE(g.accel_clipped()) << "axis " << axis << " sign " << sign;
      EXPECT_FALSE(g.gyro_clipped());
      EXPECT_FLOAT_EQ(out.y, 0.2f) << "the gyro is untouched";
      EXPECT_EQ(g.clipped_samples(), 1u);
    }
  }
}

TEST(ImuClipGuard, UnhealthyAfterTheHoldTimeThenTheReadingPasses) {
  ImuClipGuard g = guard();
  g.update(sample(Vec3{0.1f, 0.0f, 0.0f}), kDt);
  const Vec3 clipped{kGyroRange, 0.0f, 0.0f};
  // 40 ms of clipping: held; the 60 ms sample is beyond the 50 ms bound.
  for (int i = 0; i < 4; ++i) {
    EXPECT_FLOAT_EQ(g.update(sample(clipped), kDt).x, 0.1f) << i;
    EXPECT_TRUE(g.healthy()) << i;
  }
  g.update(sample(clipped), kDt);
  const Vec3 out = g.update(sample(clipped), kDt);
  EXPECT_FALSE(g.healthy());
  EXPECT_FLOAT_EQ(out.x, kGyroRange) << "a sustained clip is a real rotation at least that fast";
  // One clean sample restores it.
  g.update(sample(Vec3{0.2f, 0.0f, 0.0f}), kDt);
  EXPECT_TRUE(g.healthy());
  EXPECT_EQ(g.clipped_samples(), 6u);
  EXPECT_EQ(g.bursts(), 1u);
}

TEST(ImuClipGuard, BurstsAreSeparatedByAQuietSecond) {
  ImuClipGuard g = guard();
  const auto clip = sample(Vec3{-kGyroRange, 0.0f, 0.0f});
  const auto clean = sample(Vec3{0.0f, 0.0f, 0.0f});
  g.update(clip, kDt);
  EXPECT_TRUE(g.burst_started());
  g.update(clip, kDt);
  EXPECT_FALSE(g.burst_started()) << "the same burst";
  for (int i = 0; i < 50; ++i) g.update(clean, kDt);  // 0.5 s quiet: still the same burst
  g.update(clip, kDt);
  EXPECT_FALSE(g.burst_started());
  for (int i = 0; i < 101; ++i) g.update(clean, kDt);  // over 1 s quiet
  g.update(clip, kDt);
  EXPECT_TRUE(g.burst_started());
  EXPECT_EQ(g.bursts(), 2u);
  EXPECT_EQ(g.clipped_samples(), 4u);
}

TEST(ImuClipGuard, NonFiniteValuesAreNotClipping) {
  ImuClipGuard g = guard();
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Vec3 out = g.update(sample(Vec3{-inf, nan, inf}, Vec3{nan, inf, -inf}), kDt);
  EXPECT_FALSE(g.gyro_clipped());
  EXPECT_FALSE(g.accel_clipped());
  EXPECT_TRUE(std::isinf(out.x)) << "left to the observer's own check";
  EXPECT_EQ(g.clipped_samples(), 0u);
}

// --- In the flight application -------------------------------------------------------------------

void into_auto(Bench& b) {
  for (int i = 0; i < 250 && !b.app->calibrated(); ++i) b.still_step();
  ASSERT_TRUE(b.app->calibrated());
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  for (int i = 0; i < 30; ++i) {
    b.still_step();
    if (i % 3 == 0) b.landing_target(Eigen::Vector3f(0, 0, -1.5f), Eigen::Quaternionf::Identity(), b.t_us - 30000);
    if (i % 5 == 0) b.sticks(0);
  }
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
}

// A shock: every axis at full scale with the sign of (truth + bias), as the saturated MPU-6000 reports.
void clipped_step(Bench& b) {
  const Eigen::Vector3f g = Eigen::Vector3f::Constant(kGyroRange) - b.gyro_bias;
  const Eigen::Vector3f a = Eigen::Vector3f(kAccelRange, -kAccelRange, -kAccelRange) - b.accel_bias;
  b.hil_step(Eigen::Quaternionf::Identity(), a, g);
}

// Still steps with fixes and RC, so only the IMU can change the mode.
void hold_steps(Bench& b, int n) {
  for (int i = 0; i < n; ++i) {
    b.still_step();
    if (i % 3 == 0) b.landing_target(Eigen::Vector3f(0, 0, -1.5f), Eigen::Quaternionf::Identity(), b.t_us - 30000);
    if (i % 5 == 0) b.sticks(0);
  }
}

TEST(FirmwareAppClipping, AClippedBurstIsNotIntegratedAndIsReportedOnce) {
  Bench b;
  b.boot();
  into_auto(b);
  hold_steps(b, 100);
  const Eigen::Quaternionf before(b.app->attitude().w, b.app->attitude().x, b.app->attitude().y, b.app->attitude().z);
  const size_t statuses_before = b.statuses.size();
  for (int i = 0; i < 3; ++i) clipped_step(b);  // 30 ms: integrated, 60 deg of roll, pitch and yaw
  const Eigen::Quaternionf after(b.app->attitude().w, b.app->attitude().x, b.app->attitude().y, b.app->attitude().z);
  EXPECT_LT(before.angularDistance(after), 0.005f);
  EXPECT_LT(quad::norm(b.app->velocity()), 0.05f) << "no +-8 g kick into the position filter";
  hold_steps(b, 250);  // two status periods
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  EXPECT_EQ(b.app->counters().imu_clipped_samples, 3u);
  EXPECT_EQ(b.app->counters().imu_clip_bursts, 1u);
  EXPECT_EQ(std::count_if(b.texts.begin(), b.texts.end(),
                          [](const std::string& t) { return t == "IMU clipping: rates held, burst 1"; }),
            1);
  // The first SYS_STATUS after the clip (each goes out on both ports) has the gyro and accelerometer
  // bits cleared, the one a status period later has them set again.
  constexpr uint32_t kImuBits = 0x3u;
  ASSERT_GE(b.statuses.size(), statuses_before + 4u);
  EXPECT_EQ(b.statuses[statuses_before].onboard_control_sensors_health & kImuBits, 0u);
  EXPECT_EQ(b.statuses.back().onboard_control_sensors_health & kImuBits, kImuBits);
}

TEST(FirmwareAppClipping, ClippingLongerThanTheHoldLandsThroughTheEstimatorFailsafe) {
  Bench b;
  b.boot();
  into_auto(b);
  hold_steps(b, 50);
  for (int i = 0; i < 5; ++i) clipped_step(b);  // 50 ms: still held
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  clipped_step(b);
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  EXPECT_TRUE(b.said("LANDING: FAILSAFE estimator unhealthy"));
}

}  // namespace
