// Quaternion PD attitude controller, thesis eq. 8.38/8.39 with the shortest-rotation fix.
#include <gtest/gtest.h>

#include <random>

#include "eigen_oracle.h"
#include "quad/control/attitude_controller.h"

namespace {

using quad::Quat;
using quad::Vec3;
using quad::ctrl::AttitudeController;
using quad::ctrl::AttitudeGains;

Quat axis_angle(const Vec3& axis, float angle) {
  return quad_test::from_eigen(Eigen::Quaterniond(Eigen::AngleAxisd(angle, quad_test::to_eigen(axis).normalized())));
}

TEST(AttitudeController, DefaultsAreTable81) {
  const AttitudeGains g;
  EXPECT_EQ(g.alpha, 3.0f);
  EXPECT_EQ(g.gamma.x, 0.625f);
  EXPECT_EQ(g.gamma.y, 0.625f);
  EXPECT_EQ(g.gamma.z, 0.5f);
}

TEST(AttitudeController, AtTheDesiredAttitudeOnlyDampingActs) {
  const AttitudeController ac;
  const Quat q = axis_angle({0.2f, -0.5f, 1.0f}, 1.1f);
  const Vec3 tau = ac.update(q, {1.0f, -2.0f, 0.5f}, q);
  EXPECT_NEAR(tau.x, -0.625f * 1.0f, 1e-6f);
  EXPECT_NEAR(tau.y, -0.625f * -2.0f, 1e-6f);
  EXPECT_NEAR(tau.z, -0.5f * 0.5f, 1e-6f);
  const Vec3 ff = ac.update(q, {1.0f, -2.0f, 0.5f}, q, {1.0f, -2.0f, 0.5f});
  EXPECT_NEAR(quad::norm(ff), 0.0f, 1e-6f);
}

// Rolled right of the desired attitude: the torque rolls left; and likewise for pitch and yaw.
TEST(AttitudeController, TorqueOpposesEachAxisError) {
  const AttitudeController ac;
  for (int axis = 0; axis < 3; ++axis) {
    Vec3 e;
    e[axis] = 1.0f;
    const Vec3 tau = ac.update(axis_angle(e, 0.2f), Vec3{}, Quat::identity());
    EXPECT_NEAR(tau[axis], -3.0f * std::sin(0.1f), 1e-5f) << axis;  // -alpha sin(angle/2)
    EXPECT_NEAR(tau[(axis + 1) % 3], 0.0f, 1e-6f);
  }
}

// q and -q are the same attitude: the torque must not depend on the representative, and past 180 deg
// the vehicle turns the other way (the short way).
TEST(AttitudeController, ShortestRotation) {
  const AttitudeController ac;
  const Quat q_d = axis_angle({0.0f, 0.0f, 1.0f}, 0.7f);
  const Quat q = q_d * axis_angle({1.0f, 0.0f, 0.0f}, 3.0f);
  const Vec3 a = ac.update(q, Vec3{}, q_d);
  const Vec3 b = ac.update(-q, Vec3{}, q_d);
  const Vec3 c = ac.update(q, Vec3{}, -q_d);
  EXPECT_LT(quad::norm(a - b), 1e-6f);
  EXPECT_LT(quad::norm(a - c), 1e-6f);
  EXPECT_LT(ac.update(q_d * axis_angle({1.0f, 0.0f, 0.0f}, 3.1f), Vec3{}, q_d).x, 0.0f);  // 178 deg: back
  EXPECT_GT(ac.update(q_d * axis_angle({1.0f, 0.0f, 0.0f}, 3.2f), Vec3{}, q_d).x, 0.0f);  // 183 deg: onwards
}

// The error quaternion against Eigen: Q~ = Q_d^-1 Q, canonical; random attitudes.
TEST(AttitudeController, ErrorMatchesEigen) {
  std::mt19937 rng(3);
  for (int k = 0; k < 10000; ++k) {
    const Eigen::Quaterniond q = quad_test::random_rotation(rng), q_d = quad_test::random_rotation(rng);
    Eigen::Quaterniond e = q_d.conjugate() * q;
    if (e.w() < 0.0) e.coeffs() = -e.coeffs();
    const Quat got = quad::ctrl::attitude_error(quad_test::from_eigen(q), quad_test::from_eigen(q_d));
    ASSERT_GE(got.w, 0.0f);
    ASSERT_NEAR(got.w, e.w(), 2e-6);
    ASSERT_NEAR(got.x, e.x(), 2e-6);
    ASSERT_NEAR(got.y, e.y(), 2e-6);
    ASSERT_NEAR(got.z, e.z(), 2e-6);
  }
}

// The controller puts sign(q~0) into the gain instead of negating the error quaternion (a saving on
// the AVR): the torque must be the law of eq. 8.39 as printed, with Eigen's product, on both sides of
// q~0 = 0 and with a rate feed-forward.
TEST(AttitudeController, TorqueMatchesEquation839WrittenOut) {
  std::mt19937 rng(839);
  std::uniform_real_distribution<double> w(-3.0, 3.0);
  const AttitudeGains g;
  const AttitudeController ac(g);
  int negative_scalar = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Quaterniond q = quad_test::random_rotation(rng), qd = quad_test::random_rotation(rng);
    const Eigen::Vector3d omega(w(rng), w(rng), w(rng)), omega_d(w(rng), w(rng), w(rng));
    const Eigen::Quaterniond e = qd.conjugate() * q;  // eq. 8.38
    if (e.w() < 0.0) ++negative_scalar;
    const double s = e.w() < 0.0 ? -1.0 : 1.0;
    const Eigen::Vector3d gamma = quad_test::to_eigen(g.gamma);
    const Eigen::Vector3d tau = -g.alpha * s * e.vec() - gamma.cwiseProduct(omega - omega_d);  // eq. 8.39
    const Vec3 got = ac.update(quad_test::from_eigen(q), quad_test::from_eigen(omega), quad_test::from_eigen(qd),
                               quad_test::from_eigen(omega_d));
    ASSERT_LT((quad_test::to_eigen(got) - tau).norm(), 1e-5) << "case " << i;
    const Vec3 no_ff = ac.update(quad_test::from_eigen(q), quad_test::from_eigen(omega), quad_test::from_eigen(qd));
    const Eigen::Vector3d tau0 = -g.alpha * s * e.vec() - gamma.cwiseProduct(omega);
    ASSERT_LT((quad_test::to_eigen(no_ff) - tau0).norm(), 1e-5) << "case " << i;
  }
  EXPECT_GT(negative_scalar, 500);  // both signs of q~0 were exercised
}

// The controller writes part of eq. 8.38/8.39 out in components (fewer helper calls on the AVR); it must
// be the same float arithmetic as the helper form, bit for bit (tuned gains, both signs of q~0).
TEST(AttitudeController, ComponentFormIsBitIdenticalToTheHelperForm) {
  std::mt19937 rng(838);
  std::uniform_real_distribution<double> w(-3.0, 3.0);
  AttitudeGains g;
  g.alpha = 6.75f;
  g.gamma = Vec3{0.405f, 0.405f, 1.0f};
  const AttitudeController ac(g);
  for (int i = 0; i < 5000; ++i) {
    const Quat q = quad_test::from_eigen(quad_test::random_rotation(rng));
    const Quat qd = quad_test::from_eigen(quad_test::random_rotation(rng));
    const Vec3 omega{float(w(rng)), float(w(rng)), float(w(rng))};
    const Quat e = quad::conjugate(qd) * q;
    const float gain = e.w < 0.0f ? g.alpha : -g.alpha;
    const Vec3 want = e.vec() * gain - quad::hadamard(g.gamma, omega);
    const Vec3 got = ac.update(q, omega, qd);
    ASSERT_EQ(got.x, want.x) << i;
    ASSERT_EQ(got.y, want.y) << i;
    ASSERT_EQ(got.z, want.z) << i;
  }
}

TEST(AttitudeController, ValidationNamesTheBadField) {
  AttitudeGains g;
  EXPECT_EQ(quad::ctrl::validate(g), nullptr);
  g.alpha = 0.0f;
  EXPECT_STREQ(quad::ctrl::validate(g), "alpha");
  g = AttitudeGains{};
  g.gamma.z = -0.1f;
  EXPECT_STREQ(quad::ctrl::validate(g), "gamma");
}

}  // namespace
