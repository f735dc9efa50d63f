// The freestanding math core against Eigen (double precision): 1000+ random cases per operation plus the
// edge cases (zero vectors, rotations near pi, pitch near +-90 deg, non-unit input quaternions).
//
// Tolerances: the core computes in float (24-bit mantissa, eps 1.2e-7). Products of O(1) quantities are
// held to 1e-5 absolute; angles from trigonometric inverses to 1e-4 rad (about 0.006 deg), except
// where a conversion is ill-conditioned by nature (stated at the test).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "eigen_oracle.h"

using namespace quad;
using namespace quad_test;

namespace {

constexpr int kCases = 2000;
constexpr double kTol = 1e-5;
constexpr double kAngleTol = 1e-4;

void expect_near(const Vec3& a, const Eigen::Vector3d& b, double tol) {
  EXPECT_NEAR(a.x, b.x(), tol);
  EXPECT_NEAR(a.y, b.y(), tol);
  EXPECT_NEAR(a.z, b.z(), tol);
}

void expect_near(const Mat3& a, const Eigen::Matrix3d& b, double tol) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.m[i][j], b(i, j), tol) << "entry (" << i << "," << j << ")";
}

// Same rotation, either sign.
void expect_same_rotation(const Quat& a, const Eigen::Quaterniond& b, double tol) {
  EXPECT_LT(rotation_distance(to_eigen(a), b), tol);
}

Eigen::Matrix3d eigen_zyx(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Largest error seen over a test's cases, printed when the test ends so the margin to the stated
// tolerance is visible in the log; every case is also asserted against the tolerance.
class Worst {
 public:
  Worst(const char* what, double tol) : what_(what), tol_(tol) {}
  Worst(const Worst&) = delete;
  Worst& operator=(const Worst&) = delete;
  ~Worst() { std::printf("[ worst    ] %-60s %9.3g  (tolerance %.3g)\n", what_, max_, tol_); }
  void check(double err, int i) {
    max_ = std::max(max_, err);
    EXPECT_LE(err, tol_) << what_ << ", case " << i;
  }

 private:
  const char* what_;
  double tol_;
  double max_ = 0.0;
};

double max_abs_diff(const Mat3& a, const Eigen::Matrix3d& b) { return (to_eigen(a) - b).cwiseAbs().maxCoeff(); }
double max_abs_diff(const Vec3& a, const Eigen::Vector3d& b) { return (to_eigen(a) - b).cwiseAbs().maxCoeff(); }
double max_abs_diff(const Quat& a, const Eigen::Quaterniond& b) { return (to_eigen(a).coeffs() - b.coeffs()).cwiseAbs().maxCoeff(); }

// A non-unit quaternion: a uniformly random rotation times a norm drawn log-uniformly from [1e-3, 1e3]
// (case 0 and 1 take the ends exactly, case 2 a typical integration drift of 1 + 1e-3), rounded to float.
// Oracles work on the float values (converted to double exactly), so input rounding is not an error.
Quat random_non_unit(std::mt19937& rng, int i) {
  std::uniform_real_distribution<double> e(-3.0, 3.0);
  const double scale = i == 0 ? 1e-3 : i == 1 ? 1e3 : i == 2 ? 1.0 + 1e-3 : std::pow(10.0, e(rng));
  const Eigen::Quaterniond q = random_rotation(rng);
  return {static_cast<float>(q.w() * scale), static_cast<float>(q.x() * scale), static_cast<float>(q.y() * scale),
          static_cast<float>(q.z() * scale)};
}

// ZYX angles of a rotation matrix, in double (the inverse of eq. 3.8; ill-conditioned at pitch +-90 deg).
Eigen::Vector3d zyx_angles(const Eigen::Matrix3d& r) {
  return {std::atan2(r(2, 1), r(2, 2)), std::asin(std::max(-1.0, std::min(1.0, -r(2, 0)))), std::atan2(r(1, 0), r(0, 0))};
}

class MathCore : public ::testing::Test {
 protected:
  std::mt19937 rng{20261122};
};

TEST_F(MathCore, VectorOperationsMatchEigen) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Vector3d a = random_vector(rng, 2.0), b = random_vector(rng, 2.0);
    const Vec3 fa = from_eigen(a), fb = from_eigen(b);
    EXPECT_NEAR(dot(fa, fb), a.dot(b), kTol * (1 + a.norm() * b.norm()));
    expect_near(cross(fa, fb), a.cross(b), kTol * (1 + a.norm() * b.norm()));
    EXPECT_NEAR(norm(fa), a.norm(), kTol * (1 + a.norm()));
    expect_near(normalized(fa), a.normalized(), kTol);
    expect_near(fa + fb, a + b, kTol);
    expect_near(fa - fb, a - b, kTol);
    expect_near(fa * 0.5f, a * 0.5, kTol);
  }
}

TEST_F(MathCore, ZeroVectorNormalisesToZeroNotNaN) {
  const Vec3 z = normalized(Vec3{});
  EXPECT_EQ(z.x, 0.0f);
  EXPECT_EQ(z.y, 0.0f);
  EXPECT_EQ(z.z, 0.0f);
  const Vec3 tiny = normalized(Vec3{1e-30f, 0.0f, 0.0f});
  EXPECT_TRUE(is_finite(tiny));
  EXPECT_FALSE(is_finite(Vec3{std::numeric_limits<float>::quiet_NaN(), 0, 0}));
  EXPECT_FALSE(is_finite(Vec3{0, std::numeric_limits<float>::infinity(), 0}));
}

TEST_F(MathCore, SkewIsTheCrossProductMatrix) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Vector3d a = random_vector(rng, 2.0), b = random_vector(rng, 2.0);
    expect_near(skew(from_eigen(a)) * from_eigen(b), a.cross(b), kTol * (1 + a.norm() * b.norm()));
    Eigen::Matrix3d s;
    s << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
    expect_near(skew(from_eigen(a)), s, kTol);
    // Skew-symmetry: sk(a)^T = -sk(a).
    expect_near(transpose(skew(from_eigen(a))), -s, kTol);
  }
}

TEST_F(MathCore, MatrixOperationsMatchEigen) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Matrix3d a = Eigen::Matrix3d::Random(), b = Eigen::Matrix3d::Random();
    const Eigen::Vector3d v = random_vector(rng, 1.0);
    const Mat3 fa = from_eigen(a), fb = from_eigen(b);
    expect_near(fa * fb, a * b, kTol);
    expect_near(fa * from_eigen(v), a * v, kTol);
    expect_near(mul_transpose(fa, from_eigen(v)), a.transpose() * v, kTol);
    expect_near(transpose(fa), a.transpose(), 1e-7);
    EXPECT_NEAR(determinant(fa), a.determinant(), kTol);
    expect_near(outer(from_eigen(v), from_eigen(v)), v * v.transpose(), kTol * (1 + v.squaredNorm()));
  }
}

// pi_x = ||x|| I - x x^T (thesis eq. 4.7): for unit x it is the orthogonal projector.
TEST_F(MathCore, ProjectionMatchesDefinitionAndIsOrthogonalForUnitAxis) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Vector3d x = random_vector(rng, 1.5), y = random_vector(rng, 1.5);
    const Eigen::Matrix3d p = x.norm() * Eigen::Matrix3d::Identity() - x * x.transpose();
    expect_near(projection(from_eigen(x)), p, kTol * (1 + x.squaredNorm()));
    expect_near(project(from_eigen(x), from_eigen(y)), p * y, kTol * (1 + x.squaredNorm()) * (1 + y.norm()));
    const Eigen::Vector3d u = x.normalized();
    const Vec3 pu = project(from_eigen(u), from_eigen(y));
    EXPECT_NEAR(dot(pu, from_eigen(u)), 0.0, kTol * (1 + y.norm()));
  }
  // Zero axis: pi_0 = 0, finite.
  const Mat3 p0 = projection(Vec3{});
  EXPECT_TRUE(is_finite(p0));
  EXPECT_EQ(determinant(p0), 0.0f);
}

// sat_Delta(x) = x min(1, Delta/||x||)   (thesis eq. 4.9)
TEST_F(MathCore, SaturationKeepsDirectionAndBoundsNorm) {
  std::uniform_real_distribution<double> d(0.001, 0.1);
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Vector3d x = random_vector(rng, 0.05);
    const double delta = d(rng);
    const Eigen::Vector3d expect = x * std::min(1.0, delta / x.norm());
    const Vec3 s = sat_delta(from_eigen(x), static_cast<float>(delta));
    expect_near(s, expect, 1e-7);
    EXPECT_LE(norm(s), delta * (1 + 1e-6));
  }
  const Vec3 z = sat_delta(Vec3{}, 0.03f);
  EXPECT_TRUE(is_finite(z));
  EXPECT_EQ(norm(z), 0.0f);
}

TEST_F(MathCore, QuaternionProductConjugateAndRotationMatchEigen) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond p = random_rotation(rng), q = random_rotation(rng);
    const Eigen::Vector3d v = random_vector(rng, 3.0);
    const Quat fp = from_eigen(p), fq = from_eigen(q);
    const Eigen::Quaterniond pq = p * q;
    const Quat fpq = fp * fq;
    EXPECT_NEAR(fpq.w, pq.w(), kTol);
    EXPECT_NEAR(fpq.x, pq.x(), kTol);
    EXPECT_NEAR(fpq.y, pq.y(), kTol);
    EXPECT_NEAR(fpq.z, pq.z(), kTol);
    const Quat c = conjugate(fq);
    // Eigen's conjugate of the same (float) quaternion: negation is exact, so all four components must
    // agree bit for bit.
    const Eigen::Quaterniond qc = to_eigen(fq).conjugate();
    EXPECT_EQ(c.w, qc.w());
    EXPECT_EQ(c.x, qc.x());
    EXPECT_EQ(c.y, qc.y());
    EXPECT_EQ(c.z, qc.z());
    // v_I = q v_B q^-1 (eq. 3.14) is Eigen's active rotation q * v.
    expect_near(rotate(fq, from_eigen(v)), q * v, kTol * (1 + v.norm()));
    expect_near(rotate_inverse(fq, from_eigen(v)), q.conjugate() * v, kTol * (1 + v.norm()));
  }
}

TEST_F(MathCore, NormaliseHandlesNonUnitZeroAndNaN) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond q = random_rotation(rng);
    std::uniform_real_distribution<double> s(1e-3, 1e3);
    const double scale = s(rng);
    const Quat raw{static_cast<float>(q.w() * scale), static_cast<float>(q.x() * scale),
                   static_cast<float>(q.y() * scale), static_cast<float>(q.z() * scale)};
    const Quat n = normalized(raw);
    EXPECT_NEAR(norm(n), 1.0, 1e-6);
    expect_same_rotation(n, q, kAngleTol);
    // A non-unit input to to_dcm after normalisation gives a proper rotation.
    EXPECT_NEAR(determinant(to_dcm(n)), 1.0, 1e-5);
  }
  const Quat zero = normalized(Quat{0, 0, 0, 0});
  EXPECT_EQ(zero.w, 1.0f);
  const Quat nan = normalized(Quat{std::numeric_limits<float>::quiet_NaN(), 0, 0, 0});
  EXPECT_TRUE(is_finite(nan));
}

// Operations documented to accept any non-zero quaternion (they normalise internally, or return a
// normalised result) must give, for s q with any s > 0, what Eigen gives for the unit quaternion q.
// Tolerances: float round-off of the normalisation (1e-7 relative) plus that of each operation; roll and
// yaw of to_euler are held to 2e-6 / cos(pitch) rad (their conditioning), the rest to the figures below.
TEST_F(MathCore, NonUnitQuaternionsIntoNormalisingOperationsMatchEigenOnTheNormalisedQuaternion) {
  Worst w_norm("normalized(s q) vs Eigen q/|q| (components)", 1e-6);
  Worst w_canon("canonical(s q) = +-(s q), w >= 0 (components / |q|)", 0.0);
  Worst w_euler_dcm("to_euler(s q): DCM of the angles vs Eigen R(q/|q|)", 2e-6);
  Worst w_euler_pitch("to_euler(s q): pitch vs Eigen (rad)", 2e-6);
  Worst w_euler_ry("to_euler(s q): roll, yaw vs Eigen (rad * cos(pitch))", 2e-6);
  Worst w_rv("to_rotation_vector(s q) vs Eigen AngleAxis (rad)", 2e-6);
  Worst w_rv_back("from_rotation_vector(to_rotation_vector(s q)) vs q (rad)", 2e-6);
  Worst w_angle("angle_between(s a, t b) vs Eigen angularDistance (rad)", 2e-6);
  Worst w_angle_self("angle_between(s a, -t a) (rad)", 2e-6);
  Worst w_so("integrate_second_order(s q): vs Eigen q exp(w T) - 0.1 x^3 (rad)", 2e-6);
  Worst w_so_norm("integrate_second_order(s q): | |result| - 1 |", 1e-6);
  std::uniform_real_distribution<double> dt(1e-4, 0.01);
  for (int i = 0; i < kCases; ++i) {
    const Quat raw = random_non_unit(rng, i), raw_b = random_non_unit(rng, i + 3);
    const Eigen::Quaterniond qd = to_eigen(raw), qh = qd.normalized(), qh_b = to_eigen(raw_b).normalized();
    const Eigen::Matrix3d rh = qh.toRotationMatrix();

    w_norm.check(max_abs_diff(normalized(raw), qh), i);

    const Quat c = canonical(raw);
    EXPECT_GE(c.w, 0.0f);
    w_canon.check(std::min(max_abs_diff(c, qd), max_abs_diff(c, Eigen::Quaterniond(-qd.coeffs()))) / qd.norm(), i);

    // to_euler: the angles must describe R(q/|q|), and match Eigen's angles where they are defined.
    const Euler e = to_euler(raw);
    w_euler_dcm.check(max_abs_diff(dcm_from_euler(e), rh), i);
    const Eigen::Vector3d ref = zyx_angles(rh);
    w_euler_pitch.check(std::abs(e.pitch - ref.y()), i);
    const double cp = std::cos(ref.y());
    if (cp > 1e-2) {
      w_euler_ry.check(std::abs(std::remainder(e.roll - ref.x(), 2 * M_PI)) * cp, i);
      w_euler_ry.check(std::abs(std::remainder(e.yaw - ref.z(), 2 * M_PI)) * cp, i);
    }

    // to_rotation_vector: Eigen's AngleAxis picks the angle in [0, pi] (the w >= 0 representative), as
    // the core does; within 1e-3 rad of pi the axis sign is a free choice, so compare the rotation there.
    const Vec3 rv = to_rotation_vector(raw);
    const Eigen::AngleAxisd aa(qh);
    if (aa.angle() < M_PI - 1e-3) w_rv.check(max_abs_diff(rv, aa.axis() * aa.angle()), i);
    w_rv_back.check(rotation_distance(to_eigen(from_rotation_vector(rv)), qh), i);

    w_angle.check(std::abs(angle_between(raw, raw_b) - qh.angularDistance(qh_b)), i);
    w_angle_self.check(std::abs(angle_between(raw, raw * -3.7f)), i);

    const Eigen::Vector3d om = random_vector(rng, 3.0);
    const double t = dt(rng);
    const Eigen::Quaterniond expect = qh * Eigen::Quaterniond(Eigen::AngleAxisd(om.norm() * t, om.normalized()));
    const Quat so = integrate_second_order(raw, from_eigen(om), static_cast<float>(t));
    const double x = 0.5 * t * om.norm();
    w_so.check(std::max(0.0, rotation_distance(to_eigen(so), expect) - 0.1 * x * x * x), i);
    w_so_norm.check(std::abs(to_eigen(so).norm() - 1.0), i);
  }
}

// to_dcm and rotate are the cheap unit-quaternion forms of eq. 3.18 and eq. 3.14 (no normalisation: they
// run in the AVR loop). For q = s u with u a unit quaternion, eq. 3.18 as printed (1 - 2(y^2 + z^2) on the
// diagonal) gives s^2 R(u) + (1 - s^2) I, which is neither R(u) nor the s^2 R(u) of the homogeneous eq.
// 3.16; rotate() is the same map applied to v. The header documents exactly this, and it is checked here
// against Eigen's R(u). Tolerance 1e-6 * (1 + s^2) (* (1 + |v|)): float round-off of entries of size s^2.
TEST_F(MathCore, NonUnitQuaternionsIntoToDcmAndRotateGiveTheDocumentedMap) {
  Worst w_dcm("to_dcm(s u) vs s^2 R(u) + (1 - s^2) I, / (1 + s^2)", 1e-6);
  Worst w_rot("rotate(s u, v) vs (s^2 R(u) + (1 - s^2) I) v, / ((1 + s^2)(1 + |v|))", 1e-6);
  Worst w_inv("rotate_inverse(s u, v) vs (s^2 R(u)^T + (1 - s^2) I) v, / (..)", 1e-6);
  Worst w_drift("|q| = 1 + d, |d| < 1e-2: |rotate - R(u) v| / (2 |s^2 - 1| |v|)", 1.0 + 1e-3);
  for (int i = 0; i < kCases; ++i) {
    const Quat raw = random_non_unit(rng, i);
    const Eigen::Quaterniond qd = to_eigen(raw);
    const double s2 = qd.squaredNorm();
    const Eigen::Matrix3d rh = qd.normalized().toRotationMatrix();
    const Eigen::Matrix3d id = Eigen::Matrix3d::Identity();
    const Eigen::Vector3d v = random_vector(rng, 3.0);
    const double scale = (1.0 + s2) * (1.0 + v.norm());
    w_dcm.check(max_abs_diff(to_dcm(raw), s2 * rh + (1.0 - s2) * id) / (1.0 + s2), i);
    w_rot.check(max_abs_diff(rotate(raw, from_eigen(v)), (s2 * rh + (1.0 - s2) * id) * v) / scale, i);
    w_inv.check(max_abs_diff(rotate_inverse(raw, from_eigen(v)), (s2 * rh.transpose() + (1.0 - s2) * id) * v) / scale, i);
  }
  // The documented error bound for a slightly drifted norm (what an integrator leaves between
  // renormalisations): |rotate(q, v) - R(u) v| = |s^2 - 1| |(R(u) - I) v| <= 2 |s^2 - 1| |v|.
  std::uniform_real_distribution<double> drift(-1e-2, 1e-2);
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond u = random_rotation(rng);
    const double s = 1.0 + drift(rng);
    const Quat raw = from_eigen(Eigen::Quaterniond(u.coeffs() * s));
    const Eigen::Quaterniond qd = to_eigen(raw);
    const double s2 = qd.squaredNorm();
    const Eigen::Vector3d v = random_vector(rng, 3.0);
    const Eigen::Vector3d err = to_eigen(rotate(raw, from_eigen(v))) - qd.normalized() * v;
    w_drift.check(err.norm() / (2.0 * std::abs(s2 - 1.0) * v.norm() + 1e-6 * (1.0 + v.norm())), i);
  }
}

// The quaternion product, the conjugate and the exact propagator are homogeneous: they do not normalise
// and the norm passes through (|p q| = |p| |q|, q conj(q) = |q|^2, |integrate_exact(q)| = |q|). Against
// Eigen's product on the same non-unit quaternions; tolerances relative to the result's norm.
TEST_F(MathCore, NonUnitQuaternionsInProductConjugateAndExactPropagatorScaleHomogeneously) {
  Worst w_prod("p (x) q vs Eigen p * q (non-unit), / (|p| |q|)", 1e-6);
  Worst w_conj("q (x) conjugate(q) vs |q|^2 (1, 0, 0, 0), / |q|^2", 1e-6);
  Worst w_exact("integrate_exact(s u) vs Eigen (s u) * exp(w T), / s", 1e-6);
  std::uniform_real_distribution<double> dt(1e-4, 0.05);
  for (int i = 0; i < kCases; ++i) {
    const Quat p = random_non_unit(rng, i), q = random_non_unit(rng, i + 1);
    const Eigen::Quaterniond pd = to_eigen(p), qd = to_eigen(q);
    w_prod.check(max_abs_diff(p * q, pd * qd) / (pd.norm() * qd.norm()), i);

    const Quat c = conjugate(q);
    const Eigen::Quaterniond cd = qd.conjugate();
    EXPECT_EQ(c.w, cd.w());
    EXPECT_EQ(c.x, cd.x());
    EXPECT_EQ(c.y, cd.y());
    EXPECT_EQ(c.z, cd.z());
    const double n2 = qd.squaredNorm();
    w_conj.check(max_abs_diff(q * c, Eigen::Quaterniond(n2, 0, 0, 0)) / n2, i);

    const Eigen::Vector3d om = random_vector(rng, 3.0);
    const double t = dt(rng);
    const Eigen::Quaterniond expect = qd * Eigen::Quaterniond(Eigen::AngleAxisd(om.norm() * t, om.normalized()));
    w_exact.check(max_abs_diff(integrate_exact(q, from_eigen(om), static_cast<float>(t)), expect) / qd.norm(), i);
  }
}

TEST_F(MathCore, DcmFromQuaternionMatchesEigen) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond q = random_rotation(rng);
    expect_near(to_dcm(from_eigen(q)), q.toRotationMatrix(), kTol);
  }
}

// to_dcm() folds the factor 2 of eq. 3.18 into one operand (x * (y + y) instead of 2 (x y)) to halve its
// multiplications on the AVR. Doubling is exact in binary floating point, so the result must be
// bit-identical to eq. 3.18 written out, also for non-unit input.
TEST_F(MathCore, DcmIsBitIdenticalToEquation318AsPrinted) {
  std::uniform_real_distribution<float> c(-1.5f, 1.5f);
  for (int i = 0; i < kCases; ++i) {
    const Quat q{c(rng), c(rng), c(rng), c(rng)};
    const float w = q.w, x = q.x, y = q.y, z = q.z;
    const float ref[3][3] = {{1.0f - 2.0f * (y * y + z * z), 2.0f * (x * y - w * z), 2.0f * (x * z + w * y)},
                             {2.0f * (x * y + w * z), 1.0f - 2.0f * (x * x + z * z), 2.0f * (y * z - w * x)},
                             {2.0f * (x * z - w * y), 2.0f * (y * z + w * x), 1.0f - 2.0f * (x * x + y * y)}};
    const Mat3 r = to_dcm(q);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) ASSERT_EQ(r.m[a][b], ref[a][b]) << "entry (" << a << "," << b << ") case " << i;
  }
}

TEST_F(MathCore, QuaternionFromDcmRoundTripsIncludingNearPi) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond q = random_rotation(rng);
    const Quat back = from_dcm(from_eigen(q.toRotationMatrix()));
    expect_same_rotation(back, q, kAngleTol);
    EXPECT_GE(back.w, 0.0f);
  }
  // Rotations of exactly pi and within 1e-3 rad of pi about random axes: the trace is ~ -1, where the
  // naive formula divides by ~0.
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Vector3d axis = random_vector(rng, 1.0).normalized();
    const double angle = M_PI - (i % 2 == 0 ? 0.0 : 1e-3 * (i % 7));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis));
    const Quat back = from_dcm(from_eigen(q.toRotationMatrix()));
    ASSERT_TRUE(is_finite(back));
    expect_same_rotation(back, q, kAngleTol);
  }
}

TEST_F(MathCore, EulerMatchesEigenZyx) {
  std::uniform_real_distribution<double> ang(-M_PI, M_PI), pit(-M_PI / 2 + 0.01, M_PI / 2 - 0.01);
  for (int i = 0; i < kCases; ++i) {
    const Euler e{static_cast<float>(ang(rng)), static_cast<float>(pit(rng)), static_cast<float>(ang(rng))};
    const Eigen::Matrix3d r = eigen_zyx(e.roll, e.pitch, e.yaw);
    expect_near(dcm_from_euler(e), r, kTol);                               // eq. 3.8
    expect_same_rotation(from_euler(e), Eigen::Quaterniond(r), kAngleTol);  // eq. 3.19
    const Euler back = to_euler(from_euler(e));                            // eq. 3.20 (corrected)
    // Away from the singularity the angles come back; pitch within 0.01 rad of 90 deg makes roll and
    // yaw ill-conditioned (float round-off in q is amplified by 1/cos(pitch) <= 100), hence the 2e-3.
    const double tol = std::abs(e.pitch) > 1.4 ? 2e-3 : kAngleTol;
    EXPECT_NEAR(back.roll, e.roll, tol);
    EXPECT_NEAR(back.pitch, e.pitch, kAngleTol);
    EXPECT_NEAR(wrap_pi(back.yaw - e.yaw), 0.0, tol);
  }
}

// At and around the lock threshold (1 -+ sin(pitch) < 1e-13, pitch within ~4.5e-7 rad of +-90 deg):
// finite, |pitch| <= 90 deg, the same attitude to 2e-6 (DCM entries), and exactly at +-90 deg the
// documented convention roll = 0.
TEST_F(MathCore, EulerAtGimbalLockIsFiniteAndRepresentsTheSameRotation) {
  Worst w_dcm("to_euler at/near gimbal lock: DCM vs Eigen ZYX", 2e-6);
  std::uniform_real_distribution<double> ang(-M_PI, M_PI);
  const double offsets[] = {0.0, 1e-8, 1e-7, 3e-7, 4.5e-7, 6e-7, 1e-6, 1e-4, 2e-4};
  for (int i = 0; i < kCases; ++i) {
    const double off = offsets[(i / 2) % 9];
    const double pitch = (i % 2 ? 1 : -1) * (M_PI / 2 - off);
    const Eigen::Matrix3d r = eigen_zyx(ang(rng), pitch, ang(rng));
    const Euler e = to_euler(from_eigen(Eigen::Quaterniond(r)));
    ASSERT_TRUE(is_finite(e.roll) && is_finite(e.pitch) && is_finite(e.yaw));
    EXPECT_LE(std::abs(e.pitch), kHalfPi);
    if (off == 0.0) EXPECT_EQ(e.roll, 0.0f) << "case " << i;
    // The angles must describe the same attitude even though the split between roll and yaw is free.
    w_dcm.check(max_abs_diff(dcm_from_euler(e), r), i);
  }
  // Pitch exactly +-90 deg in float through the core's eq. 3.19.
  for (float sign : {1.0f, -1.0f}) {
    const Euler e = to_euler(from_euler(Euler{0.7f, sign * kHalfPi, -2.1f}));
    EXPECT_EQ(e.roll, 0.0f);
    EXPECT_NEAR(e.pitch, sign * kHalfPi, 1e-6);
    w_dcm.check(max_abs_diff(dcm_from_euler(e), eigen_zyx(0.7f, sign * kHalfPi, -2.1f)), 0);
  }
}

// Pitch 1e-6 .. 1e-2 rad away from +-90 deg (log-uniform, both signs, random roll and yaw): the round
// trip Euler -> quaternion -> Euler must give back the same attitude (DCM of the angles against Eigen's
// ZYX matrix of the input angles) and the same pitch. Roll and yaw alone are ill-conditioned here (only
// yaw - sign(pitch) roll is well determined at the pole), so they are checked through the DCM and that
// combination. The quaternion comes both from the core's eq. 3.19 and from Eigen. Tolerance 2e-6 (DCM
// entries, radians): float round-off, nothing left of the former snap of pitch to +-90 deg within
// |sin(pitch)| > 0.99999, which cost up to 4.5e-3 rad.
TEST_F(MathCore, EulerRoundTripNearPlusMinus90DegPitchMatchesEigen) {
  Worst w_dcm("euler -> from_euler -> to_euler: DCM vs Eigen ZYX", 2e-6);
  Worst w_pitch("euler -> from_euler -> to_euler: pitch (rad)", 2e-6);
  Worst w_comb("euler -> from_euler -> to_euler: yaw - sign(pitch) roll (rad)", 2e-6);
  Worst w_dcm_e("euler -> Eigen quaternion -> to_euler: DCM vs Eigen ZYX", 2e-6);
  Worst w_pitch_e("euler -> Eigen quaternion -> to_euler: pitch (rad)", 2e-6);
  std::uniform_real_distribution<double> ang(-M_PI, M_PI), lg(-6.0, -2.0);
  for (int i = 0; i < kCases; ++i) {
    const double off = i < 2 ? 1e-6 : i < 4 ? 1e-2 : std::pow(10.0, lg(rng));
    const double sign = i % 2 ? 1.0 : -1.0;
    const Euler in{static_cast<float>(ang(rng)), static_cast<float>(sign * (M_PI / 2 - off)), static_cast<float>(ang(rng))};
    const Eigen::Matrix3d r = eigen_zyx(in.roll, in.pitch, in.yaw);  // of the float angles: no input rounding

    const Euler back = to_euler(from_euler(in));
    ASSERT_TRUE(is_finite(back.roll) && is_finite(back.pitch) && is_finite(back.yaw));
    EXPECT_LE(std::abs(back.pitch), kHalfPi);
    w_dcm.check(max_abs_diff(dcm_from_euler(back), r), i);
    w_pitch.check(std::abs(back.pitch - in.pitch), i);
    const double comb_in = in.yaw - sign * in.roll, comb_back = back.yaw - sign * back.roll;
    w_comb.check(std::abs(std::remainder(comb_back - comb_in, 2 * M_PI)), i);

    const Euler back_e = to_euler(from_eigen(Eigen::Quaterniond(r)));
    w_dcm_e.check(max_abs_diff(dcm_from_euler(back_e), r), i);
    w_pitch_e.check(std::abs(back_e.pitch - in.pitch), i);
  }
}

// Thesis eq. 4.14: exp(T/2 A(Omega)) q, checked against Eigen's exact rotation q * exp(Omega T).
TEST_F(MathCore, ExactPropagatorMatchesRotationAtConstantRate) {
  std::uniform_real_distribution<double> dt(1e-4, 0.05);
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond q = random_rotation(rng);
    const Eigen::Vector3d w = random_vector(rng, 3.0);
    const double t = dt(rng);
    const Eigen::Quaterniond expect = q * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm() * t, w.normalized()));
    const Quat got = integrate_exact(from_eigen(q), from_eigen(w), static_cast<float>(t));
    expect_same_rotation(got, expect, kAngleTol);
    EXPECT_NEAR(norm(got), 1.0, 1e-5);  // the exact exponential preserves the norm
  }
  // Zero rate: no motion, no NaN.
  const Quat q0 = integrate_exact(Quat{0.5f, 0.5f, 0.5f, 0.5f}, Vec3{}, 0.01f);
  EXPECT_NEAR(q0.w, 0.5f, 1e-7);
  // A large rotation in one step (3 rad): still exact.
  const Eigen::Vector3d w(0, 0, 300.0);
  const Quat big = integrate_exact(Quat::identity(), from_eigen(w), 0.01f);
  expect_same_rotation(big, Eigen::Quaterniond(Eigen::AngleAxisd(3.0, Eigen::Vector3d::UnitZ())), kAngleTol);
}

// The second-order form (thesis sec. 4.3) agrees with the exact one to O((T|w|/2)^3) per step.
TEST_F(MathCore, SecondOrderPropagatorErrorIsThirdOrder) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond q = random_rotation(rng);
    const Eigen::Vector3d w = random_vector(rng, 4.0);
    const double t = 0.01;
    const Quat exact = integrate_exact(from_eigen(q), from_eigen(w), static_cast<float>(t));
    const Quat approx = integrate_second_order(from_eigen(q), from_eigen(w), static_cast<float>(t));
    const double x = 0.5 * t * w.norm();
    EXPECT_LT(rotation_distance(to_eigen(exact), to_eigen(approx)), 2e-6 + 0.1 * x * x * x);
    EXPECT_NEAR(norm(approx), 1.0, 1e-5);
  }
}

TEST_F(MathCore, RotationVectorRoundTrip) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond q = random_rotation(rng);
    const Eigen::AngleAxisd aa(q);
    const Vec3 rv = to_rotation_vector(from_eigen(q));
    EXPECT_LE(norm(rv), M_PI + 1e-5);
    expect_same_rotation(from_rotation_vector(rv), q, kAngleTol);
    if (aa.angle() < M_PI - 1e-3) expect_near(rv, aa.axis() * aa.angle(), 1e-4);  // Eigen also picks the angle in [0, pi]
  }
  const Vec3 zero = to_rotation_vector(Quat::identity());
  EXPECT_EQ(norm(zero), 0.0f);
}

TEST_F(MathCore, AngleBetweenMatchesEigen) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Quaterniond a = random_rotation(rng), b = random_rotation(rng);
    EXPECT_NEAR(angle_between(from_eigen(a), from_eigen(b)), a.angularDistance(b), kAngleTol);
    // Sign invariance: q and -q are the same attitude.
    EXPECT_NEAR(angle_between(from_eigen(a), -from_eigen(a)), 0.0, kAngleTol);
  }
}

TEST_F(MathCore, SmallMatrixAlgebraMatchesEigen) {
  for (int i = 0; i < kCases; ++i) {
    const Eigen::Matrix2d a = Eigen::Matrix2d::Random() + 2.0 * Eigen::Matrix2d::Identity();
    const Eigen::Matrix2d b = Eigen::Matrix2d::Random();
    Mat2 fa, fb;
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) {
        fa(r, c) = static_cast<float>(a(r, c));
        fb(r, c) = static_cast<float>(b(r, c));
      }
    const Mat2 prod = fa * fb;
    Mat2 inv;
    ASSERT_TRUE(inverse(fa, inv));
    const Eigen::Matrix2d ainv = a.inverse();
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) {
        EXPECT_NEAR(prod(r, c), (a * b)(r, c), kTol);
        EXPECT_NEAR(inv(r, c), ainv(r, c), 1e-4 * (1 + std::abs(ainv(r, c))));
        EXPECT_EQ(transpose(fa)(r, c), fa(c, r));
      }
  }
  Mat2 singular;  // all zeros
  Mat2 out = Mat2::identity();
  EXPECT_FALSE(inverse(singular, out));
  EXPECT_EQ(out(0, 0), 1.0f);  // untouched
}

TEST_F(MathCore, ScalarHelpers) {
  EXPECT_NEAR(sincf(0.0f), 1.0f, 0.0f);
  for (int i = 1; i < kCases; ++i) {
    const double x = i * 1e-3;
    EXPECT_NEAR(sincf(static_cast<float>(x)), std::sin(x) / x, 1e-6);
    EXPECT_NEAR(wrap_pi(static_cast<float>(x * 10)), std::remainder(x * 10, 2 * M_PI), 1e-4);
  }
  // Huge finite angles still end in (-pi, pi] (a plain subtraction loop would never terminate).
  for (float a : {1e10f, -3e12f, 123456.7f, 3.4e38f}) {
    const float w = wrap_pi(a);
    EXPECT_GT(w, -M_PI - 1e-6);
    EXPECT_LE(w, M_PI + 1e-6);
  }
  EXPECT_EQ(safe_asinf(1.5f), asinf(1.0f));
  EXPECT_EQ(safe_sqrtf(-1e-9f), 0.0f);
  EXPECT_FALSE(is_finite(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_FALSE(is_finite(-std::numeric_limits<float>::infinity()));
  EXPECT_TRUE(is_finite(std::numeric_limits<float>::max()));
}

}  // namespace
