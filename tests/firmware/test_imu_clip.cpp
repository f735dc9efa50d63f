// IMU clipping: the guard on its own (which axes count as clipped, the held rate, the time bound, the
// bursts) and inside the flight application (a clipped burst in AUTO leaves the estimate alone and is
// reported once; a clip longer than IMU_CLIP_HOLD lands through the estimator failsafe).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "float_cases.h"
#include "app_bench.h"
#include "quad/firmware/imu_clip.h"
#include "quad/firmware/params.h"

namespace {

using quad_test::bits_of;

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
  quad::fw::test::ready_to_arm(b);
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

// The guard stops adding to its quiet time once past the burst gap: against the plain implementation
// written out here (which keeps adding), outputs, flags, counters and health must be
// identical on random sequences with samples at, just below and just above the limits, non-finite ones,
// and every configuration kind (including a zero hold and odd ranges).
namespace {

struct ReferenceGuard {
  float gyro_limit = 0.0f, accel_limit = 0.0f, hold_s = 0.0f;
  Vec3 last_good;
  float clipping_for_s = 0.0f, quiet_for_s = ImuClipGuard::kBurstGapS;
  bool gyro_clipped = false, accel_clipped = false, burst_started = false;
  uint32_t clipped_samples = 0, bursts = 0;
  static bool at_limit(float x, float limit) { return quad::is_finite(x) && quad::absf(x) >= limit; }
  void configure(float g, float a, float h) {
    gyro_limit = ImuClipGuard::kClipFraction * g;
    accel_limit = ImuClipGuard::kClipFraction * a;
    hold_s = h;
  }
  bool healthy() const { return clipping_for_s <= hold_s; }
  Vec3 update(const quad::hal::ImuSample& raw, float dt) {
    Vec3 gyro = raw.gyro;
    bool gc = false;
    for (int i = 0; i < 3; ++i) {
      if (at_limit(raw.gyro[i], gyro_limit)) gc = true;
      else if (quad::is_finite(raw.gyro[i])) last_good[i] = raw.gyro[i];
    }
    const bool ac = at_limit(raw.accel.x, accel_limit) || at_limit(raw.accel.y, accel_limit) || at_limit(raw.accel.z, accel_limit);
    gyro_clipped = gc;
    accel_clipped = ac;
    burst_started = false;
    if (!gc && !ac) {
      clipping_for_s = 0.0f;
      quiet_for_s += dt;
      return gyro;
    }
    ++clipped_samples;
    if (quiet_for_s >= ImuClipGuard::kBurstGapS) {
      burst_started = true;
      ++bursts;
    }
    quiet_for_s = 0.0f;
    clipping_for_s += dt;
    if (!healthy()) return gyro;
    for (int i = 0; i < 3; ++i) {
      if (at_limit(raw.gyro[i], gyro_limit)) gyro[i] = last_good[i];
    }
    return gyro;
  }
};

}  // namespace

TEST(ImuClipGuard, GuardMatchesTheReferenceImplementation) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  struct Config { float g, a, h; };
  for (const Config& cfg : {Config{kGyroRange, kAccelRange, 0.05f}, Config{kGyroRange, kAccelRange, 0.0f},
                            Config{1.0f, 10.0f, 0.5f}, Config{0.0f, kAccelRange, 0.05f}, Config{-1.0f, -5.0f, 0.05f},
                            Config{nan, nan, 0.05f}, Config{inf, inf, 0.05f}}) {
    ImuClipGuard g;
    ReferenceGuard r;
    g.configure(cfg.g, cfg.a, cfg.h);
    r.configure(cfg.g, cfg.a, cfg.h);
    std::mt19937 rng(static_cast<uint32_t>(bits_of(cfg.g) ^ bits_of(cfg.h)));
    const float gl = ImuClipGuard::kClipFraction * cfg.g, al = ImuClipGuard::kClipFraction * cfg.a;
    auto pick = [&](float limit, float typical) {
      switch (rng() % 12) {
        case 0: return limit;
        case 1: return -limit;
        case 2: return std::nextafter(limit, 0.0f);
        case 3: return -std::nextafter(limit, inf);
        case 4: return nan;
        case 5: return (rng() % 2) ? inf : -inf;
        case 6: return (rng() % 2) ? 0.0f : -0.0f;
        default: return typical * (static_cast<float>(rng() % 2001) / 1000.0f - 1.0f);
      }
    };
    // Long quiet stretches between clips, so bursts begin and end (the 1 s gap) many times.
    for (int i = 0; i < 60000; ++i) {
      const bool clipping_phase = (i / 50) % 7 == 0 || (i / 300) % 5 == 0;
      quad::hal::ImuSample s;
      if (clipping_phase) {
        s.gyro = Vec3{pick(gl, 3.0f), pick(gl, 3.0f), pick(gl, 3.0f)};
        s.accel = Vec3{pick(al, 20.0f), pick(al, 20.0f), pick(al, 20.0f)};
      } else {
        std::uniform_real_distribution<float> u(-1.0f, 1.0f);
        s.gyro = Vec3{u(rng), u(rng), u(rng)};
        s.accel = Vec3{u(rng), u(rng), -9.8f + u(rng)};
      }
      const float dt = (rng() % 3 == 0) ? 0.0025f : 0.01f;
      const Vec3 a = g.update(s, dt);
      const Vec3 b = r.update(s, dt);
      SCOPED_TRACE(testing::Message() << "config " << cfg.g << " sample " << i);
      ASSERT_EQ(bits_of(a.x), bits_of(b.x));
      ASSERT_EQ(bits_of(a.y), bits_of(b.y));
      ASSERT_EQ(bits_of(a.z), bits_of(b.z));
      ASSERT_EQ(g.gyro_clipped(), r.gyro_clipped);
      ASSERT_EQ(g.accel_clipped(), r.accel_clipped);
      ASSERT_EQ(g.burst_started(), r.burst_started);
      ASSERT_EQ(g.healthy(), r.healthy());
      ASSERT_EQ(g.clipped_samples(), r.clipped_samples);
      ASSERT_EQ(g.bursts(), r.bursts);
    }
    if (cfg.g == kGyroRange) EXPECT_GT(r.bursts, 3u);  // the sequence does exercise the burst logic
  }
}
