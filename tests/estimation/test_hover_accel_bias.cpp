// In-flight accelerometer x/y bias learned while hovering (quad/estimation/hover_accel_bias.h): the mean
// of a hovering quadrotor's horizontal specific force is the bias; noise averages out, the estimate
// holds while not hovering, and it never exceeds its limit (a steady wind's lean is not a bias).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "float_cases.h"
#include "quad/estimation/hover_accel_bias.h"

namespace {

using quad_test::bits_of;

using quad::Vec3;
using quad::est::HoverAccelBias;

constexpr float kDt = 0.01f;

// A hovering vehicle's accelerometer: (b_x, b_y, -g + b_z) plus MPU-6000 white noise at 100 Hz
// (4e-3 m/s^2/sqrt(Hz) as the simulator's default, times sqrt(100 Hz / 2) for the sampled band) and
// vibration noise of 0.3 m/s^2.
struct Accelerometer {
  Vec3 bias;
  std::mt19937 rng{7};
  std::normal_distribution<float> n{0.0f, 0.3f};
  Vec3 sample() { return Vec3{bias.x + n(rng), bias.y + n(rng), -9.80665f + bias.z + n(rng)}; }
};

TEST(HoverAccelBias, LearnsTheBiasWithinAFewTimeConstants) {
  HoverAccelBias b;
  b.configure(10.0f, 0.15f);
  Accelerometer a;
  a.bias = Vec3{0.08f, -0.05f, 0.2f};
  for (int k = 0; k < 3000; ++k) b.update(a.sample(), true, kDt);  // 30 s = 3 tau
  std::printf("[figure] bias (0.08, -0.05) m/s^2, tau 10 s, 0.3 m/s^2 noise: after 30 s (%.4f, %.4f)\n", b.bias().x,
              b.bias().y);
  // The noise left in the mean: 0.3 sqrt(dt / (2 tau)) = 0.0067 m/s^2; the bounds are 3 sigma.
  EXPECT_NEAR(b.bias().x, 0.08f * (1.0f - std::exp(-3.0f)), 0.02f);
  EXPECT_NEAR(b.bias().y, -0.05f * (1.0f - std::exp(-3.0f)), 0.02f);
  EXPECT_EQ(b.bias().z, 0.0f) << "z is never learned (thrust is along z)";
  for (int k = 0; k < 6000; ++k) b.update(a.sample(), true, kDt);
  EXPECT_NEAR(b.bias().x, 0.08f, 0.02f);
  EXPECT_NEAR(b.bias().y, -0.05f, 0.02f);
}

TEST(HoverAccelBias, FollowsARandomWalkAndHoldsWhileNotHovering) {
  HoverAccelBias b;
  b.configure(10.0f, 0.15f);
  Accelerometer a;
  std::mt19937 rng(3);
  std::normal_distribution<float> walk(0.0f, 6e-3f * std::sqrt(kDt));  // the RotorS / PX4 IMU random walk
  double sq = 0;
  int n = 0;
  for (int k = 0; k < 60000; ++k) {  // 10 min
    a.bias.x += walk(rng);
    a.bias.y += walk(rng);
    b.update(a.sample(), true, kDt);
    if (k > 3000) {
      sq += std::pow(b.bias().x - a.bias.x, 2) + std::pow(b.bias().y - a.bias.y, 2);
      ++n;
    }
  }
  const double rms = std::sqrt(sq / n);
  std::printf("[figure] random walk 6e-3 m/s^2/sqrt(s), 10 min: tracking error %.4f m/s^2 rms (tilt %.3f deg)\n", rms,
              rms / 9.80665 * 57.29578);
  // Untracked, the bias would have walked 6e-3 sqrt(600) = 0.147 m/s^2 (1 sigma) in the 10 min.
  EXPECT_LT(rms, 0.03) << "a fifth of the untracked drift";
  const Vec3 held = b.bias();
  Accelerometer leaning;  // manoeuvring: drag and acceleration in the body x/y reading
  leaning.bias = Vec3{1.0f, -1.0f, 0.0f};
  for (int k = 0; k < 1000; ++k) b.update(leaning.sample(), false, kDt);
  EXPECT_EQ(b.bias().x, held.x) << "not hovering: held";
  EXPECT_EQ(b.bias().y, held.y);
}

TEST(HoverAccelBias, NeverLearnsMoreThanItsLimit) {
  // A steady 2 m/s breeze: the vehicle leans 2.2 deg into it and the accelerometer reads 0.39 m/s^2 of
  // drag on x. Taken for bias it would tilt the attitude estimate by as much; the limit bounds it.
  HoverAccelBias b;
  b.configure(10.0f, 0.15f);
  Accelerometer a;
  a.bias = Vec3{0.39f, -0.6f, 0.0f};
  for (int k = 0; k < 20000; ++k) b.update(a.sample(), true, kDt);
  EXPECT_FLOAT_EQ(b.bias().x, 0.15f);
  EXPECT_FLOAT_EQ(b.bias().y, -0.15f);
  b.configure(10.0f, 0.1f);
  EXPECT_FLOAT_EQ(b.bias().x, 0.1f) << "a smaller limit clamps the held value";
}

TEST(HoverAccelBias, OffBadSamplesAndSteps) {
  HoverAccelBias b;
  b.configure(0.0f, 0.15f);
  for (int k = 0; k < 1000; ++k) b.update(Vec3{0.1f, 0.1f, -9.8f}, true, kDt);
  EXPECT_EQ(b.bias().x, 0.0f) << "tau 0: off";
  b.configure(1.0f, 0.15f);
  for (int k = 0; k < 1000; ++k) b.update(Vec3{0.1f, 0.1f, -9.8f}, true, kDt);
  const Vec3 learned = b.bias();
  EXPECT_NEAR(learned.x, 0.1f, 1e-4f);
  b.update(Vec3{NAN, 0.0f, -9.8f}, true, kDt);
  b.update(Vec3{0.0f, INFINITY, -9.8f}, true, kDt);
  b.update(Vec3{0.0f, 0.0f, -9.8f}, true, 0.0f);
  b.update(Vec3{0.0f, 0.0f, -9.8f}, true, -1.0f);
  EXPECT_EQ(b.bias().x, learned.x) << "non-finite samples and bad steps change nothing";
  EXPECT_EQ(b.bias().y, learned.y);
  b.update(Vec3{0.05f, 0.05f, -9.8f}, true, 100.0f);  // a step longer than tau: the sample, no overshoot
  EXPECT_FLOAT_EQ(b.bias().x, 0.05f);
  b.configure(0.0f, 0.15f);
  EXPECT_EQ(b.bias().x, 0.0f) << "turning it off clears it";
}

}  // namespace

// update() against the equations written out here (the gate, the gain's limit of 1, the clamp): the
// learned bias must be bit-identical for random samples, non-finite
// ones, steps of every kind (0, negative, NaN, infinite, long enough for a gain of 1) and configurations
// (off, a zero limit, an infinite limit, a tiny time constant).
#include <cstring>
#include <limits>

namespace {

struct ReferenceBias {
  float inv_tau = 0.0f, limit = 0.0f, bx = 0.0f, by = 0.0f;
  void configure(float tau_s, float l) {
    inv_tau = tau_s > 0.0f ? 1.0f / tau_s : 0.0f;
    limit = quad::maxf(l, 0.0f);
    if (inv_tau == 0.0f) bx = by = 0.0f;
    bx = quad::clampf(bx, -limit, limit);
    by = quad::clampf(by, -limit, limit);
  }
  void update(const Vec3& a, bool hovering, float dt) {
    if (!hovering || inv_tau == 0.0f || !quad::is_finite(a) || !(dt > 0.0f)) return;
    const float k = quad::minf(dt * inv_tau, 1.0f);
    bx = quad::clampf(bx + k * (a.x - bx), -limit, limit);
    by = quad::clampf(by + k * (a.y - by), -limit, limit);
  }
};

}  // namespace

TEST(HoverAccelBias, UpdateMatchesTheReferenceImplementation) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  struct Config { float tau, limit; };
  for (const Config& c : {Config{10.0f, 0.15f}, Config{0.0f, 0.15f}, Config{10.0f, 0.0f}, Config{10.0f, inf},
                          Config{1e-3f, 0.15f}, Config{1e-38f, 1.0f}, Config{inf, 0.15f}, Config{600.0f, nan}}) {
    HoverAccelBias b;
    ReferenceBias r;
    b.configure(c.tau, c.limit);
    r.configure(c.tau, c.limit);
    std::mt19937 rng(static_cast<uint32_t>(bits_of(c.tau) ^ bits_of(c.limit)));
    std::normal_distribution<float> n(0.0f, 0.5f);
    const float dts[] = {0.01f, 0.0f, -0.01f, nan, inf, 20.0f, 1e-40f, -0.0f};
    for (int i = 0; i < 20000; ++i) {
      Vec3 a{n(rng), n(rng), -9.8f + n(rng)};
      if (rng() % 20 == 0) a[static_cast<int>(rng() % 3)] = (rng() % 2) ? nan : -inf;
      if (rng() % 50 == 0) a.x = (rng() % 2) ? c.limit : -c.limit;
      const bool hovering = rng() % 5 != 0;
      const float dt = (rng() % 6 == 0) ? dts[rng() % 8] : kDt;
      b.update(a, hovering, dt);
      r.update(a, hovering, dt);
      ASSERT_EQ(bits_of(b.bias().x), bits_of(r.bx)) << "tau " << c.tau << " limit " << c.limit << " step " << i;
      ASSERT_EQ(bits_of(b.bias().y), bits_of(r.by)) << "tau " << c.tau << " limit " << c.limit << " step " << i;
      ASSERT_EQ(bits_of(b.bias().z), bits_of(0.0f));
    }
  }
}
