// The freestanding math core against Eigen (double precision): 1000+ random cases per operation plus the
// edge cases (zero vectors, rotations near pi, pitch near +-90 deg, non-unit input quaternions).
//
// Tolerances: the core computes in float (24-bit mantissa, eps 1.2e-7). Products of O(1) quantities are
// held to 1e-5 absolute; angles from trigonometric inverses to 1e-4 rad (about 0.006 deg), except
// where a conversion is ill-conditioned by nature (stated at the test).
#include <gtest/gtest.h>

#include <cmath>
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
    const Eigen::Quaterniond qc = q.conjugate();
    EXPECT_NEAR(c.w, qc.w(), 1e-7);
    EXPECT_NEAR(c.x, qc.x(), 1e-7);
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

TEST_F(MathCore, EulerAtGimbalLockIsFiniteAndRepresentsTheSameRotation) {
  std::uniform_real_distribution<double> ang(-M_PI, M_PI);
  for (int i = 0; i < kCases; ++i) {
    const double pitch = (i % 2 ? 1 : -1) * (M_PI / 2 - (i % 3) * 1e-4);
    const Eigen::Matrix3d r = eigen_zyx(ang(rng), pitch, ang(rng));
    const Euler e = to_euler(from_eigen(Eigen::Quaterniond(r)));
    ASSERT_TRUE(is_finite(e.roll) && is_finite(e.pitch) && is_finite(e.yaw));
    EXPECT_LE(std::abs(e.pitch), M_PI / 2 + 1e-6);
    // The angles must describe the same attitude even though the split between roll and yaw is free.
    expect_near(dcm_from_euler(e), r, 2e-3);
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
