// The star's attitude in the conditioned observer (the extension of thesis eq. 4.9 in docs/estimation.md,
// "The star's attitude in the thesis pair"): the gains, one correction against rotations written in
// Eigen double, the transport of a delayed error to the present, and the steady states of a constant
// offset in the fixes against the linear model of the observer with and without gravity.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <random>

#include <Eigen/Geometry>

#include "eigen_oracle.h"
#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/vector_attitude.h"

namespace {

using quad::Quat;
using quad::Vec3;
using quad::est::AttitudeFixWeights;
using quad::est::ConditionedObserver;
using quad::est::ObserverParams;
using quad_test::from_eigen;
using quad_test::to_eigen;

constexpr double kDeg = M_PI / 180.0;
constexpr float kG = 9.80665f;

Eigen::Quaterniond exp_rv(const Eigen::Vector3d& rv) {
  const double a = rv.norm();
  return a > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(a, rv / a)) : Eigen::Quaterniond::Identity();
}

// vex(P_a(R)) of R = exp(e): sin|e| along e.
Eigen::Vector3d vex_pa(const Eigen::Vector3d& e) {
  const Eigen::Matrix3d r = exp_rv(e).toRotationMatrix();
  const Eigen::Matrix3d a = 0.5 * (r - r.transpose());
  return {a(2, 1), a(0, 2), a(1, 0)};
}

Eigen::Vector3d log_rv(const Eigen::Quaterniond& q) {
  const Eigen::AngleAxisd aa(q.w() < 0.0 ? Eigen::Quaterniond(-q.coeffs()) : q);
  return aa.axis() * aa.angle();
}

TEST(AttitudeFixGain, IsTheVarianceRatioPerAxisCappedAndZeroForABadCovariance) {
  const AttitudeFixWeights w{0.001f, 0.003f, 0.0087f, 0.0017f, 0.2f};
  // Station-like covariance: 0.34 deg about x, 0.30 deg about y, 0.017 deg about z, with off-diagonals.
  const double sx = 0.34 * kDeg, sy = 0.30 * kDeg, sz = 0.017 * kDeg, fl = 0.0017;
  const float cov[6] = {float(sx * sx), 1e-7f, 0.0f, float(sy * sy), 0.0f, float(sz * sz)};
  const Vec3 g = quad::est::attitude_fix_gain(cov, w);
  EXPECT_NEAR(g.x, 1e-6 / (1e-6 + sx * sx + fl * fl), 1e-6);
  EXPECT_NEAR(g.y, 1e-6 / (1e-6 + sy * sy + fl * fl), 1e-6);
  EXPECT_FLOAT_EQ(g.z, 0.2f) << "9e-6 / (9e-6 + 2.9e-6) = 0.76, capped";
  const Vec3 none = quad::est::attitude_fix_gain(nullptr, w);
  const double d = 0.0087 * 0.0087;
  EXPECT_NEAR(none.x, 1e-6 / (1e-6 + d), 1e-6);
  EXPECT_NEAR(none.z, 9e-6 / (9e-6 + d), 1e-6);
  float bad[6] = {NAN, 0.0f, 0.0f, -1.0f, 0.0f, INFINITY};
  const Vec3 b = quad::est::attitude_fix_gain(bad, w);
  EXPECT_EQ(b.x, 0.0f);
  EXPECT_EQ(b.y, 0.0f);
  EXPECT_EQ(b.z, 0.0f);
}

// The star's quarter-turn symmetry resolved by the one-product form, against the four candidates
// t_k (x) q_BS* compared in double.
TEST(AttitudeFromStar, PicksTheQuarterTurnNearestTheEstimate) {
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Quaterniond truth = quad_test::random_rotation(rng);
    const Eigen::Quaterniond estimate = truth * exp_rv(quad_test::random_vector(rng, 0.1));
    // The star turned by a quarter turn k about down: the station reports its axes, ambiguous by k.
    const int k = i % 4;
    const Eigen::Quaterniond q_is(Eigen::AngleAxisd(k * M_PI / 2, Eigen::Vector3d::UnitZ()));
    const Eigen::Quaterniond q_bs = truth.conjugate() * q_is;
    double best = -1.0;
    Eigen::Quaterniond expected;
    for (int j = 0; j < 4; ++j) {
      const Eigen::Quaterniond c =
          Eigen::Quaterniond(Eigen::AngleAxisd(j * M_PI / 2, Eigen::Vector3d::UnitZ())) * q_bs.conjugate();
      const double dot = std::fabs(c.coeffs().dot(estimate.coeffs()));
      if (dot > best) {
        best = dot;
        expected = c;
      }
    }
    const Quat got = quad::est::attitude_from_star(from_eigen(q_bs), from_eigen(estimate));
    EXPECT_LT(quad_test::rotation_distance(to_eigen(got), expected), 1e-5) << i;
    EXPECT_LT(quad_test::rotation_distance(to_eigen(got), truth), 1e-5) << i;
  }
}

// One fix with no motion since its capture: the estimate turns by gain_i xi_i about body axis i, xi =
// vex(P_a(R_hat^T R_meas)) (the body-frame error's sin), to the accuracy of the second-order small rotation
// (|d|^3 / 12).
TEST(ObserverAttitudeFix, OneFixTurnsTheEstimateByTheGainTimesTheBodyError) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond q_hat = quad_test::random_rotation(rng);
    const Eigen::Vector3d e(0.02 * (i % 5 - 2) / 2.0, -0.015, 0.3 * ((i % 3) - 1));
    ConditionedObserver obs;
    obs.reset(from_eigen(q_hat), Vec3{});
    const Vec3 gain{0.1f, 0.05f, 0.2f};
    ASSERT_TRUE(obs.correct_attitude(from_eigen(q_hat * exp_rv(e)), from_eigen(q_hat), gain));
    const Eigen::Vector3d xi = vex_pa(e);
    const Eigen::Vector3d d(0.1 * xi.x(), 0.05 * xi.y(), 0.2 * xi.z());
    const Eigen::Quaterniond expected = q_hat * exp_rv(d);
    EXPECT_LT(quad_test::rotation_distance(to_eigen(obs.attitude()), expected), 1e-5 + std::pow(d.norm(), 3) / 12) << i;
    EXPECT_NEAR(to_eigen(obs.attitude()).norm(), 1.0, 1e-6);
  }
}

// A delayed fix: the estimate has turned by a rotation D since the capture (q_now = q_then D); the
// correction is the same rotation in NED as at the capture time: q_new q_now* = q_then exp(d) q_then*.
TEST(ObserverAttitudeFix, ADelayedErrorIsCarriedToThePresentInNed) {
  std::mt19937 rng(5);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond q_then = quad_test::random_rotation(rng);
    const Eigen::Quaterniond q_now = q_then * exp_rv(quad_test::random_vector(rng, 0.6));
    const Eigen::Vector3d e = quad_test::random_vector(rng, 0.02);
    ConditionedObserver obs;
    obs.reset(from_eigen(q_now), Vec3{});
    ASSERT_TRUE(obs.correct_attitude(from_eigen(q_then * exp_rv(e)), from_eigen(q_then), Vec3{0.5f, 0.5f, 0.5f}));
    const Eigen::Quaterniond applied_ned = to_eigen(obs.attitude()) * q_now.conjugate();
    const Eigen::Quaterniond expected_ned = q_then * exp_rv(0.5 * vex_pa(e)) * q_then.conjugate();
    EXPECT_LT(quad_test::rotation_distance(applied_ned, expected_ned), 2e-5) << i;
  }
}

TEST(ObserverAttitudeFix, ZeroGainLargeTiltAndNonFiniteFixesChangeNothing) {
  const Eigen::Quaterniond q_hat(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  ConditionedObserver obs;
  obs.reset(from_eigen(q_hat), Vec3{0.001f, 0.0f, 0.0f});
  const Quat before = obs.attitude();
  const Quat meas = from_eigen(q_hat * exp_rv(Eigen::Vector3d(0.01, 0.0, 0.2)));
  EXPECT_TRUE(obs.correct_attitude(meas, before, Vec3{}));
  EXPECT_LT(quad_test::rotation_distance(to_eigen(obs.attitude()), q_hat), 1e-6);
  const Quat kept = obs.attitude();
  // Tilt 0.11 rad off (beyond kMaxAttitudeFixTilt): refused; a heading 0.5 rad off is taken.
  EXPECT_FALSE(obs.correct_attitude(from_eigen(q_hat * exp_rv(Eigen::Vector3d(0.11, 0.0, 0.0))), before,
                                    Vec3{0.1f, 0.1f, 0.1f}));
  EXPECT_EQ(obs.attitude().x, kept.x);
  EXPECT_FALSE(obs.correct_attitude(Quat{NAN, 0.0f, 0.0f, 0.0f}, before, Vec3{0.1f, 0.1f, 0.1f}));
  EXPECT_EQ(obs.attitude().x, kept.x);
  EXPECT_EQ(obs.gyro_bias().x, 0.001f) << "the bias is the observer's own";
  EXPECT_TRUE(obs.correct_attitude(from_eigen(q_hat * exp_rv(Eigen::Vector3d(0.0, 0.0, 0.5))), before,
                                   Vec3{0.1f, 0.1f, 0.1f}));
  EXPECT_NEAR(quad_test::rotation_distance(to_eigen(obs.attitude()), q_hat), 0.1 * std::sin(0.5), 1e-4);
}

// A still, level vehicle; every 1/30 s a fix whose attitude is rolled by a constant offset, captured
// 40 ms before it is applied (the estimate at the capture time from a history of the estimates).
struct OffsetRun {
  double roll_deg = 0.0;     // the estimate's roll, mean over the last second (the fixes' sawtooth out)
  double bias_x = 0.0;       // its gyro bias about x at the end, rad/s
};

OffsetRun fly_offset(const ObserverParams& p, bool gravity, double offset_rad, float gain, double seconds) {
  ConditionedObserver obs(p);
  obs.reset(Quat::identity(), Vec3{});
  const double dt = 0.01;
  const Eigen::Quaterniond meas = exp_rv(Eigen::Vector3d(offset_rad, 0.0, 0.0));
  std::deque<Quat> history;  // the estimate at each step, newest last
  const Vec3 accel = gravity ? Vec3{0.0f, 0.0f, -kG} : Vec3{};  // zero: refused by the norm gate
  const int steps = static_cast<int>(seconds / dt);
  double next_fix = 0.1;
  double roll_sum = 0.0;
  int roll_n = 0;
  for (int k = 0; k < steps; ++k) {
    obs.update(Vec3{}, accel, Vec3{}, false, static_cast<float>(dt));
    if (k >= steps - 100) {
      roll_sum += log_rv(to_eigen(obs.attitude())).x() / kDeg;
      ++roll_n;
    }
    history.push_back(obs.attitude());
    if (history.size() > 10) history.pop_front();
    const double t = (k + 1) * dt;
    if (t + 1e-9 >= next_fix) {
      next_fix += 1.0 / 30.0;
      const Quat q_then = history[history.size() - 1 - 4];  // 40 ms ago
      obs.correct_attitude(from_eigen(meas), q_then, Vec3{gain, gain, gain});
    }
  }
  OffsetRun r;
  r.roll_deg = roll_sum / roll_n;
  r.bias_x = obs.gyro_bias().x;
  return r;
}

// Without gravity the fixes alone: the estimate converges to the fix's attitude.
TEST(ObserverAttitudeFix, AConstantOffsetAloneIsConvergedTo) {
  const OffsetRun r = fly_offset(ObserverParams{}, false, 1.0 * kDeg, 1.0f / 30.0f, 20.0);
  EXPECT_NEAR(r.roll_deg, 1.0, 1e-3);
}

// With gravity and no bias learning (k3 = 0) the linear model d(theta)/dt = -k1 theta + r (theta_s -
// theta), r = gain x 30 Hz, settles at theta = r theta_s / (k1 + r): half the offset at r = k1 = 1/s.
// With the table's bias gain the integral takes the difference up: the tilt returns to gravity's and
// the gyro bias settles at +r theta_s (b enters as Omega_m - b: -b + r theta_s = 0 at rest).
TEST(ObserverAttitudeFix, AgainstGravityTheOffsetSettlesAtTheRatesRatioThenTheBiasTakesItUp) {
  ObserverParams p;
  p.k3 = 0.0f;
  const double offset = 1.0 * kDeg;
  for (const float gain : {1.0f / 30.0f, 3.0f / 30.0f}) {
    const double r = gain * 30.0;
    const OffsetRun run = fly_offset(p, true, offset, gain, 30.0);
    EXPECT_NEAR(run.roll_deg, r / (p.k1 + r), 0.01) << "gain " << gain;
  }
  const OffsetRun integral = fly_offset(ObserverParams{}, true, offset, 1.0f / 30.0f, 400.0);
  EXPECT_NEAR(integral.roll_deg, 0.0, 0.015) << "half the offset without the bias";
  EXPECT_NEAR(integral.bias_x, 1.0 * offset, 0.03 * offset);
}

}  // namespace
