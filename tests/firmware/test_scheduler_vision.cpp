// Scheduler timing (grid, overruns, load, dividers) and the vision path (attitude history, eq. 8.5).
#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/Geometry>
#include <random>

#include "eigen_oracle.h"
#include "quad/firmware/frame_schedule.h"
#include "quad/firmware/vision.h"

namespace {

using quad::fw::AttitudeHistory;
using quad::fw::LoopTimer;
using quad::fw::RateDivider;

TEST(LoopTimer, FiresOnAFixedGridWithoutDrift) {
  LoopTimer t;
  t.set_rate_hz(100.0f);
  ASSERT_EQ(t.period_us(), 10000u);
  uint32_t now = 5000;
  int fired = 0;
  // Poll every 300 us for one simulated second: exactly 100 iterations, never two in one period.
  for (int i = 0; i < 3334; ++i, now += 300) fired += t.due(now) ? 1 : 0;
  EXPECT_EQ(fired, 100);
  EXPECT_EQ(t.overruns(), 0u);
}

TEST(LoopTimer, ConfigurableRates) {
  LoopTimer t;
  t.set_rate_hz(50.0f);
  EXPECT_EQ(t.period_us(), 20000u);
  t.set_rate_hz(400.0f);
  EXPECT_EQ(t.period_us(), 2500u);
  t.set_rate_hz(1000.0f);
  EXPECT_EQ(t.period_us(), 1000u);
}

TEST(LoopTimer, CountsMissedSlotsAndLongIterations) {
  LoopTimer t;
  t.set_rate_hz(100.0f);
  ASSERT_TRUE(t.due(0));
  t.begin(0);
  t.end(35000);  // 35 ms in a 10 ms period
  EXPECT_EQ(t.overruns(), 1u);
  EXPECT_EQ(t.max_exec_us(), 35000u);
  // The next call is 3.5 periods late: slots at 10, 20, 30 ms passed; 20 and 30 were missed.
  EXPECT_TRUE(t.due(35000));
  EXPECT_EQ(t.overruns(), 3u);
  // Back on the grid: the next slot is 40 ms.
  EXPECT_FALSE(t.due(39999));
  EXPECT_TRUE(t.due(40000));
}

TEST(LoopTimer, LoadTracksExecutionShare) {
  LoopTimer t;
  t.set_rate_hz(100.0f);
  uint32_t now = 0;
  for (int i = 0; i < 1000; ++i) {
    t.begin(now);
    t.end(now + 2500);  // 25 % of the period
    now += 10000;
  }
  EXPECT_NEAR(t.load_permille(), 250, 1);
  EXPECT_EQ(t.overruns(), 0u);
  EXPECT_EQ(t.iterations(), 1000u);
  // The integer share against the float formula at every execution time of a 400 Hz period, and an
  // iteration longer than the period counts as the whole period (1000).
  t.set_rate_hz(400.0f);
  for (uint32_t exec = 0; exec <= 3000; exec += 7) {
    LoopTimer u;
    u.set_rate_hz(400.0f);
    for (int i = 0; i < 1000; ++i) {
      u.begin(now);
      u.end(now + exec);
      now += 2500;
    }
    const double expected = std::min(1000.0, 1000.0 * exec / 2500.0);
    EXPECT_NEAR(u.load_permille(), expected, 1.0) << exec << " us";
  }
}

TEST(LoopTimer, SurvivesClockWrap) {
  LoopTimer t;
  t.set_rate_hz(100.0f);
  uint32_t now = 0xFFFFFFFFu - 25000u;
  int fired = 0;
  for (int i = 0; i < 100; ++i, now += 1000) fired += t.due(now) ? 1 : 0;
  EXPECT_EQ(fired, 10);
  EXPECT_EQ(t.overruns(), 0u);
}

// The firmware's telemetry streams (1, 10, 10, 1 Hz out of 100 Hz, slots 1, 0, 5, 3) never share an
// iteration, and a slot moves the grid without changing the rate.
TEST(RateDivider, SlotsKeepStreamsOutOfEachOthersIterations) {
  struct Stream {
    float hz;
    uint8_t slot;
  };
  const Stream streams[] = {{1.0f, 1}, {10.0f, 0}, {10.0f, 5}, {1.0f, 3}};
  for (const float loop_hz : {100.0f, 400.0f}) {
    RateDivider d[4];
    for (int s = 0; s < 4; ++s) d[s].configure(streams[s].hz, loop_hz, streams[s].slot);
    int runs[4] = {0, 0, 0, 0};
    int shared = 0;
    const int n = static_cast<int>(10.0f * loop_hz);  // 10 s
    for (int i = 0; i < n; ++i) {
      int fired = 0;
      for (int s = 0; s < 4; ++s) {
        if (d[s].tick()) {
          ++runs[s];
          ++fired;
        }
      }
      shared += fired > 1 ? 1 : 0;
    }
    EXPECT_EQ(shared, 0) << loop_hz << " Hz loop";
    for (int s = 0; s < 4; ++s) EXPECT_EQ(runs[s], static_cast<int>(10.0f * streams[s].hz)) << "stream " << s;
  }
  // Without slots the same streams collide: the test above would catch slots that did nothing.
  RateDivider a, b;
  a.configure(10.0f, 100.0f);
  b.configure(10.0f, 100.0f);
  int together = 0;
  for (int i = 0; i < 100; ++i) {
    const bool fa = a.tick();
    const bool fb = b.tick();
    together += fa && fb ? 1 : 0;
  }
  EXPECT_EQ(together, 10);
}

TEST(RateDivider, RunsAtTheRequestedShareOfTheLoop) {
  RateDivider d;
  d.configure(10.0f, 100.0f);
  int runs = 0;
  for (int i = 0; i < 1000; ++i) runs += d.tick() ? 1 : 0;
  EXPECT_EQ(runs, 100);
  d.configure(0.0f, 100.0f);
  for (int i = 0; i < 1000; ++i) EXPECT_FALSE(d.tick());
  d.configure(500.0f, 100.0f);  // faster than the loop: every iteration
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(d.tick());
  // Rates that do not divide the loop rate are kept on average, evenly spread.
  const float rates[] = {30.0f, 40.0f, 45.0f, 60.0f, 70.0f, 7.0f, 0.5f, 99.0f};
  for (float rate : rates) {
    d.configure(rate, 100.0f);
    int n = 0, longest_gap = 0, gap = 0;
    for (int i = 0; i < 10000; ++i) {
      if (d.tick()) {
        ++n;
        longest_gap = std::max(longest_gap, gap);
        gap = 0;
      } else {
        ++gap;
      }
    }
    EXPECT_NEAR(n, rate * 100.0f, 1.0f) << rate << " Hz out of 100 Hz, 100 s";
    EXPECT_LE(longest_gap, static_cast<int>(100.0f / rate)) << rate << " Hz: no bunching";
  }
  d.configure(33.3f, 400.0f);
  int n = 0;
  for (int i = 0; i < 40000; ++i) n += d.tick() ? 1 : 0;
  EXPECT_NEAR(n, 3330, 1) << "0.1 Hz resolution at 400 Hz";
}

// The 100 Hz stages of the firmware over a faster loop: each stage once per 10 ms frame, in its own
// iteration when the loop has four or more per frame, in the order correction, prediction, position
// loop, shaper; all in every iteration at 100 Hz; and, for a loop rate that does not divide, each stage
// still once per frame.
TEST(StageClock, EachStageOncePerFrameInItsOwnIteration) {
  using quad::fw::StageClock;
  for (const float loop_hz : {100.0f, 200.0f, 250.0f, 300.0f, 400.0f, 800.0f, 1000.0f, 50.0f}) {
    StageClock c;
    c.configure(100.0f, loop_hz);
    const int expected_per_frame = loop_hz <= 100.0f ? 1 : static_cast<int>(loop_hz / 100.0f);
    EXPECT_EQ(c.per_frame(), expected_per_frame) << loop_hz;
    const int n = static_cast<int>(10.0f * loop_hz);  // 10 s
    int runs[4] = {0, 0, 0, 0}, shared = 0, out_of_order = 0;
    int last[4] = {-1, -1, -1, -1};
    for (int i = 0; i < n; ++i) {
      c.tick();
      int fired = 0;
      for (uint8_t s = 0; s < 4; ++s) {
        if (!c.runs(s)) continue;
        ++runs[s];
        ++fired;
        last[s] = i;
      }
      if (fired > 1) ++shared;
      // Within a frame of four or more iterations: the prediction the iteration after the correction,
      // the position loop the one after that.
      if (c.per_frame() >= 4 && c.runs(1) && last[0] != i - 1) ++out_of_order;
      if (c.per_frame() >= 4 && c.runs(2) && last[1] != i - 1) ++out_of_order;
    }
    // 100 Hz x 10 s (50 Hz: every iteration, 500); the first frame may be cut short.
    const int frames = loop_hz <= 100.0f ? n : 1000;
    for (int s = 0; s < 4; ++s) EXPECT_NEAR(runs[s], frames, 1) << loop_hz << " Hz, stage " << s;
    if (c.per_frame() >= 4) {
      EXPECT_EQ(shared, 0) << loop_hz << " Hz: one stage per iteration";
      EXPECT_LE(out_of_order, 1) << loop_hz;  // (the cut first frame)
    }
    if (c.per_frame() == 1) EXPECT_EQ(shared, n) << "100 Hz: every stage in every iteration";
  }
}

quad::Quat random_quat(std::mt19937& rng) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  return quad::normalized(quad::Quat{n(rng), n(rng), n(rng), n(rng)});
}

TEST(AttitudeHistory, LooksUpPastAttitudesOfARotatingVehicle) {
  // A vehicle turning at a constant 1 rad/s about a tilted axis; 100 Hz, one record per iteration.
  const Eigen::Vector3f axis = Eigen::Vector3f(0.3f, -0.5f, 0.8f).normalized();
  auto truth = [&](double t) { return Eigen::Quaternionf(Eigen::AngleAxisf(static_cast<float>(t), axis)); };
  AttitudeHistory h;
  h.set_decimation(3);  // one record per 30 ms
  for (int k = 0; k <= 40; ++k) {
    const Eigen::Quaternionf q = truth(k * 0.01);
    h.push(static_cast<uint32_t>(k * 10000), quad::Quat{q.w(), q.x(), q.y(), q.z()});
  }
  EXPECT_EQ(h.size(), AttitudeHistory::kCapacity);
  // 0.27 s ago, between two records.
  const uint32_t t_query = 400000 - 270000 + 4321;
  quad::Quat q;
  ASSERT_TRUE(h.lookup(t_query, q));
  const Eigen::Quaternionf expect = truth(t_query * 1e-6);
  const float err = Eigen::Quaternionf(q.w, q.x, q.y, q.z).angularDistance(expect);
  EXPECT_LT(err, 3e-4f);
  // Older than the oldest record (12 records at 30 ms span 0.33 s): refused rather than guessed.
  EXPECT_FALSE(h.lookup(400000 - 350000, q));
  // Newer than the last push: refused.
  EXPECT_FALSE(h.lookup(400001, q));
  EXPECT_TRUE(h.lookup(400000, q));
}

TEST(AttitudeHistory, DecimationStretchesTheSpan) {
  for (float hz : {50.0f, 100.0f, 400.0f, 1000.0f}) {
    AttitudeHistory h;
    h.set_decimation(AttitudeHistory::decimation_for(hz, 0.3f));
    const uint32_t period = static_cast<uint32_t>(1e6f / hz);
    const int n = static_cast<int>(hz);  // one second
    for (int k = 0; k <= n; ++k) h.push(static_cast<uint32_t>(k) * period, quad::Quat::identity());
    quad::Quat q;
    const uint32_t now = static_cast<uint32_t>(n) * period;
    EXPECT_TRUE(h.lookup(now - 300000, q)) << hz << " Hz: 0.3 s back must still be covered";
    EXPECT_FALSE(h.lookup(now - 700000, q)) << hz << " Hz: the history is not unbounded";
  }
}

TEST(AttitudeHistory, InterpolatesAcrossTheQuaternionSignFlip) {
  AttitudeHistory h;
  // Same attitude family, the second sample given with the opposite sign.
  const quad::Quat a = quad::from_rotation_vector(quad::Vec3{0.0f, 0.0f, 3.1f});
  const quad::Quat b = -quad::from_rotation_vector(quad::Vec3{0.0f, 0.0f, 3.12f});
  h.push(0, a);
  h.push(10000, b);
  quad::Quat q;
  ASSERT_TRUE(h.lookup(5000, q));
  EXPECT_LT(quad::angle_between(q, quad::from_rotation_vector(quad::Vec3{0.0f, 0.0f, 3.11f})), 1e-3f);
}

TEST(VisionFix, StarBelowLevelVehicleMeansVehicleAboveStar) {
  // Level vehicle 1.5 m above the star (at the origin): the star is 1.5 m below, along body +z.
  const quad::Vec3 p = quad::fw::vehicle_position_from_star({0, 0, 0}, quad::Quat::identity(), {0, 0, 1.5f});
  EXPECT_NEAR(p.z, -1.5f, 1e-6f);  // NED: above = negative down
  // The star ahead-right of the vehicle: the vehicle is behind-left of the star.
  const quad::Vec3 q = quad::fw::vehicle_position_from_star({0, 0, 0}, quad::Quat::identity(), {0.2f, 0.1f, 1.5f});
  EXPECT_NEAR(q.x, -0.2f, 1e-6f);
  EXPECT_NEAR(q.y, -0.1f, 1e-6f);
}

TEST(VisionFix, AgreesWithEigenForRandomAttitudes) {
  // thesis eq. 8.5 (errata): p_I = s - R_IB p_B, i.e. the star's NED position equals the vehicle's plus
  // the rotated body vector.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  for (int i = 0; i < 200; ++i) {
    const quad::Quat q = random_quat(rng);
    const quad::Vec3 star{u(rng), u(rng), u(rng)};
    const quad::Vec3 body{u(rng), u(rng), u(rng)};
    const quad::Vec3 p = quad::fw::vehicle_position_from_star(star, q, body);
    const Eigen::Vector3f expect =
        Eigen::Vector3f(star.x, star.y, star.z) -
        Eigen::Quaternionf(q.w, q.x, q.y, q.z).toRotationMatrix() * Eigen::Vector3f(body.x, body.y, body.z);
    EXPECT_NEAR(p.x, expect.x(), 1e-5f);
    EXPECT_NEAR(p.y, expect.y(), 1e-5f);
    EXPECT_NEAR(p.z, expect.z(), 1e-5f);
  }
}

// The mount turns the station's body frame V into the IMU's B: p_B = R_BV p_V, R_BS = R_BV R_VS, with
// R_BV = Rz(yaw) Ry(pitch) Rx(roll) built by Eigen; the identity attitude (no pose fitted) stays.
TEST(CameraMount, TurnsPositionAndAttitudeIntoTheImuBodyFrame) {
  using namespace quad_test;
  const quad::Euler e{0.03f, -0.02f, 0.05f};
  quad::fw::CameraMount mount;
  mount.configure(e);
  const Eigen::Matrix3d R_BV = (Eigen::AngleAxisd(e.yaw, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(e.pitch, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(e.roll, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond q_vs = random_rotation(rng);
    const Eigen::Vector3d p_v = random_vector(rng, 2.0);
    quad::Vec3 p = from_eigen(p_v);
    float q[4] = {static_cast<float>(q_vs.w()), static_cast<float>(q_vs.x()), static_cast<float>(q_vs.y()),
                  static_cast<float>(q_vs.z())};
    mount.apply(&p, q);
    EXPECT_LT((to_eigen(p) - R_BV * p_v).norm(), 1e-5);
    const Eigen::Quaterniond q_bs(q[0], q[1], q[2], q[3]);
    EXPECT_LT(rotation_distance(q_bs, Eigen::Quaterniond(R_BV * q_vs.toRotationMatrix())), 1e-5);
  }
  quad::Vec3 p{0.0f, 0.0f, 1.5f};
  float none[4] = {1.0f, 0.0f, 0.0f, 0.0f};
  mount.apply(&p, none);
  EXPECT_EQ(none[0], 1.0f);
  EXPECT_EQ(none[1], 0.0f);
  EXPECT_NEAR(p.x, 1.5 * R_BV(0, 2), 1e-6);
  quad::fw::CameraMount zero;
  zero.configure(quad::Euler{});
  EXPECT_TRUE(zero.identity());
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// The application's checks (app_checks.h): each must return exactly what the float expression in its
// comment returns.

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "float_cases.h"
#include "quad/estimation/calibration.h"
#include "quad/firmware/app_checks.h"

using quad_test::bits_of;
using quad_test::interesting_floats;
using quad_test::next_down;
using quad_test::next_up;
using quad_test::same_float;


TEST(AppChecks, StepDtIsTheFloatFormulaForEveryElapsedTime) {
  using quad::fw::step_dt;
  std::mt19937 rng(3);
  for (uint32_t period : {1000u, 2500u, 10000u, 20000u, 1000000u}) {
    LoopTimer t;
    t.set_rate_hz(1e6f / static_cast<float>(period));
    ASSERT_EQ(t.period_us(), period);
    const float nominal = t.period_s();
    ASSERT_EQ(bits_of(nominal), bits_of(static_cast<float>(period) * 1e-6f));
    std::vector<uint32_t> elapsed = {0u, 1u, period - 1u, period, period + 1u, 5u * period, 5u * period + 1u,
                                     0x7FFFFFFFu, 0x80000000u, 0xFFFFFFFFu};
    for (int i = 0; i < 20000; ++i) elapsed.push_back(i % 2 ? rng() : rng() % (6u * period));
    for (uint32_t e : elapsed) {
      for (bool started : {false, true}) {
        // The original expression of FlightApp::step.
        float dt = started ? static_cast<float>(static_cast<int32_t>(e)) * 1e-6f : nominal;
        if (!(dt > 0.0f) || dt > 5.0f * nominal) dt = nominal;
        ASSERT_EQ(bits_of(step_dt(started, e, period, nominal)), bits_of(dt)) << e << " " << period;
      }
    }
  }
}

TEST(AppChecks, SpeedAndForceTestsAreTheNormComparisons) {
  using namespace quad::fw;
  using quad::Vec3;
  const auto vals = interesting_floats({0.05f, 0.17f, 0.3f, 0.1732f, 3.0f, 11.0f, 11.547f, 20.0f}, 3000, 11u);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> around_hover(-0.35f, 0.35f), around_fast(-25.0f, 25.0f), force(-12.0f, 12.0f);
  std::vector<Vec3> vs;
  for (size_t i = 0; i < 200000; ++i) {
    switch (i % 4) {
      case 0: vs.push_back(Vec3{vals[rng() % vals.size()], vals[rng() % vals.size()], vals[rng() % vals.size()]}); break;
      case 1: vs.push_back(Vec3{around_hover(rng), around_hover(rng), around_hover(rng)}); break;
      case 2: vs.push_back(Vec3{around_fast(rng), around_fast(rng), around_fast(rng)}); break;
      default: vs.push_back(Vec3{force(rng), force(rng), force(rng) * 0.3f}); break;
    }
  }
  // On the edges of the shortcuts: three equal axes just inside and outside 0.17, 11 and 3.
  for (float a : {0.17f, 11.0f, 3.0f, 0.3f, 20.0f}) {
    for (float x : {a, next_up(a), next_down(a)}) vs.push_back(Vec3{x, x, x});
  }
  for (const Vec3& v : vs) {
    SCOPED_TRACE(testing::Message() << v.x << " " << v.y << " " << v.z);
    ASSERT_EQ(slow_for_hover(v), quad::norm_sq(v) < quad::sqf(kHoverMaxSpeed));
    ASSERT_EQ(healthy_speed(v), quad::is_finite(v) && quad::norm_sq(v) < quad::sqf(kMaxHealthySpeed));
    if (quad::is_finite(v)) ASSERT_EQ(plausible_force(v), quad::norm_sq(v) > quad::sqf(0.3f * quad::kGravity));
    const uint8_t m = moving_axes(v);
    ASSERT_EQ((m & 1u) != 0u, std::fabs(v.x) >= kTrimMovingSpeed);
    ASSERT_EQ((m & 2u) != 0u, std::fabs(v.y) >= kTrimMovingSpeed);
    ASSERT_EQ((m & 4u) != 0u, std::fabs(v.z) >= kTrimMovingSpeed);
  }
}

TEST(AppChecks, IdentityMagCalibrationOnlyForTheDefaults) {
  using namespace quad::fw;
  Params p;
  EXPECT_TRUE(identity_calibration(p));
  // Each of the twelve parameters, moved one float step, makes it a real calibration.
  for (uint8_t i = kMagOfsX; i <= kMagSiZZ; ++i) {
    Params q;
    const float v = q.get(i);
    ASSERT_EQ(q.set(i, v == 0.0f ? 1e-6f : next_down(v)), ParamError::kNone);
    EXPECT_FALSE(identity_calibration(q)) << static_cast<int>(i);
  }
  // The default calibration is the identity on every finite field (thesis eq. 7.5 as MagCalibration
  // applies it): skipping it changes nothing but the sign of an exact zero.
  quad::est::MagCalibration c;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> f(-2.0f, 2.0f);
  for (int i = 0; i < 10000; ++i) {
    const quad::Vec3 m{f(rng), f(rng), f(rng)};
    const quad::Vec3 out = c.apply(m);
    ASSERT_EQ(bits_of(out.x), bits_of(m.x));
    ASSERT_EQ(bits_of(out.y), bits_of(m.y));
    ASSERT_EQ(bits_of(out.z), bits_of(m.z));
  }
}
