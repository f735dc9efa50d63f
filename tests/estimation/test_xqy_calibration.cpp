// R = XQY calibration (seed 002 sec. 2.4) against synthetic rotation pairs whose X and Y are known: the
// truth is the oracle (noise-free: exact; with noise: within a bound that scales with the noise), and the
// least-squares property of eq. 15-16 is checked by brute force (no small rotation of the solution lowers
// the cost J, evaluated independently in double precision).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "quad/estimation/xqy_calibration.h"

namespace {

using quad::est::RotationPair;
using quad::est::rotation_angle;
using quad::est::solve_xqy;
using quad::est::solve_y_given_x;
using quad::est::XqyOptions;
using quad::est::XqyResult;

constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix3d rot(const Eigen::Vector3d& rotation_vector) {
  const double a = rotation_vector.norm();
  if (a == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, rotation_vector / a).toRotationMatrix();
}

Eigen::Matrix3d ypr(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// The star on the floor (X = R_NS: yawed, tilted a little) and a 2° mount error (Y = R_VB).
const Eigen::Matrix3d kX = ypr(0.7, 0.01, -0.02);
const Eigen::Matrix3d kY = ypr(1.2 * kDeg, -0.9 * kDeg, 1.3 * kDeg);

// A calibration flight's attitudes: yaw over a full turn, tilts up to max_tilt about varied axes; the
// measurements R_i = X Q_i Y (eq. 11) with independent noise rotations of sigma (rad per axis) on each.
std::vector<RotationPair> flight_pairs(int n, double max_tilt, double sigma, bool yaw_only, unsigned seed,
                                       double yaw_span = 2.0 * M_PI) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> z(0.0, 1.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<RotationPair> out;
  for (int i = 0; i < n; ++i) {
    const double yaw = yaw_span * i / n;
    const Eigen::Matrix3d R_NB = yaw_only ? ypr(yaw, 0.0, 0.0) : ypr(yaw, max_tilt * u(rng), max_tilt * u(rng));
    const Eigen::Vector3d e1(z(rng), z(rng), z(rng)), e2(z(rng), z(rng), z(rng));
    RotationPair p;
    p.R = rot(sigma * e1) * R_NB;
    p.Q = (kX.transpose() * R_NB * kY.transpose()) * rot(sigma * e2);  // Q = Xᵀ R Yᵀ
    out.push_back(p);
  }
  return out;
}

double angle_between(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) { return rotation_angle(a * b.transpose()); }

TEST(XqyCalibration, NoiseFreePairsGiveXAndYExactly) {
  const XqyResult r = solve_xqy(flight_pairs(60, 15 * kDeg, 0.0, false, 1), XqyOptions{});
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_LT(angle_between(r.X, kX), 1e-9);
  EXPECT_LT(angle_between(r.Y, kY), 1e-9);
  EXPECT_LT(r.residual_rms_rad, 1e-9);
  EXPECT_NEAR(r.X.determinant(), 1.0, 1e-12);
  EXPECT_NEAR(r.Y.determinant(), 1.0, 1e-12);
}

// The station's attitude noise (~0.1° per axis) and the estimator's: the mount within less than half of
// the 0.2° the product asks, over several seeds.
TEST(XqyCalibration, NoisyPairsRecoverTheMountWellWithinTwoTenthsOfADegree) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const XqyResult r = solve_xqy(flight_pairs(400, 15 * kDeg, 0.2 * kDeg, false, seed), XqyOptions{});
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_LT(angle_between(r.Y, kY), 0.08 * kDeg) << "seed " << seed;
    EXPECT_LT(angle_between(r.X, kX), 0.08 * kDeg) << "seed " << seed;
    // Two noise rotations of sigma per axis: the residual is about sqrt(6) sigma.
    EXPECT_NEAR(r.residual_rms_rad, std::sqrt(6.0) * 0.2 * kDeg, 0.1 * kDeg);
  }
}

// More noise, larger error, in proportion: the error is a property of the noise, not of the method.
TEST(XqyCalibration, ErrorScalesWithTheNoise) {
  const XqyResult small = solve_xqy(flight_pairs(300, 15 * kDeg, 0.1 * kDeg, false, 7), XqyOptions{});
  const XqyResult large = solve_xqy(flight_pairs(300, 15 * kDeg, 1.0 * kDeg, false, 7), XqyOptions{});
  ASSERT_TRUE(small.ok && large.ok);
  const double e_small = angle_between(small.Y, kY), e_large = angle_between(large.Y, kY);
  EXPECT_GT(e_large, 3.0 * e_small);
  EXPECT_LT(e_large, 0.5 * kDeg);
}

// Eq. 15-16 minimise J = sum ||r_ij - X q_ij||²: no small rotation of the solution lowers J (brute
// force over 26 directions at two step sizes, J summed here independently of the solver; yaw over a
// quarter turn so that no relative rotation reaches the solver's 3 rad limit and every pair counts).
TEST(XqyCalibration, SolutionMinimisesTheSeedsLeastSquaresCost) {
  const std::vector<RotationPair> pairs = flight_pairs(80, 20 * kDeg, 0.5 * kDeg, false, 3, M_PI / 2.0);
  XqyOptions o;
  o.min_relative_angle_rad = 0.0;
  const XqyResult r = solve_xqy(pairs, o);
  ASSERT_TRUE(r.ok) << r.message;
  auto cost = [&](const Eigen::Matrix3d& X) {
    double j = 0.0;
    for (size_t a = 0; a < pairs.size(); ++a) {
      for (size_t b = a + 1; b < pairs.size(); ++b) {
        const Eigen::AngleAxisd ra(pairs[a].R * pairs[b].R.transpose()), qa(pairs[a].Q * pairs[b].Q.transpose());
        j += (ra.angle() * ra.axis() - X * (qa.angle() * qa.axis())).squaredNorm();
      }
    }
    return j;
  };
  const double j0 = cost(r.X);
  for (double step : {1e-4, 1e-3}) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          const Eigen::Vector3d d = step * Eigen::Vector3d(dx, dy, dz).normalized();
          EXPECT_GE(cost(rot(d) * r.X), j0 * (1.0 - 1e-12)) << "step " << step << " direction " << d.transpose();
        }
      }
    }
  }
}

// Seed errata: rotations about one axis only leave X and Y free about it; the solver says so.
TEST(XqyCalibration, RotationsAboutOneAxisAreRefused) {
  const XqyResult r = solve_xqy(flight_pairs(100, 0.0, 0.0, true, 1), XqyOptions{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("one axis"), std::string::npos) << r.message;
}

TEST(XqyCalibration, TooFewPairsAreRefused) {
  const XqyResult r = solve_xqy(flight_pairs(2, 15 * kDeg, 0.0, false, 1), XqyOptions{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("at least 3"), std::string::npos) << r.message;
}

TEST(XqyCalibration, StillSamplesAreRefused) {
  std::vector<RotationPair> pairs(50, RotationPair{kX * kY, Eigen::Matrix3d::Identity()});
  const XqyResult r = solve_xqy(pairs, XqyOptions{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("too few pairs"), std::string::npos) << r.message;
}

// The star's heading known (XqyOptions::star_heading_known, the product's layout): yaw turns alone give X
// and Y, which seed 002 as written refuses (test above). The heading is given a quarter turn off: the
// station's star frame is any of four, the one nearest the data is taken.
XqyOptions known_heading(double heading) {
  XqyOptions o;
  o.star_heading_known = true;
  o.star_heading_rad = heading;
  return o;
}

TEST(XqyCalibration, KnownStarHeadingGivesXAndYFromYawTurnsAlone) {
  const std::vector<RotationPair> pairs = flight_pairs(100, 0.0, 0.0, true, 1);
  ASSERT_FALSE(solve_xqy(pairs, XqyOptions{}).ok);
  const XqyResult r = solve_xqy(pairs, known_heading(0.7 - M_PI / 2.0));
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_LT(angle_between(r.X, kX), 1e-9);
  EXPECT_LT(angle_between(r.Y, kY), 1e-9);
}

TEST(XqyCalibration, KnownStarHeadingWithNoiseRecoversTheMount) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const XqyResult r = solve_xqy(flight_pairs(400, 2 * kDeg, 0.2 * kDeg, false, seed), known_heading(0.7));
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_LT(angle_between(r.Y, kY), 0.08 * kDeg) << "seed " << seed;
    EXPECT_LT(angle_between(r.X, kX), 0.08 * kDeg) << "seed " << seed;
  }
}

// The prior's price: an error in the assumed heading goes whole into the mount's yaw.
TEST(XqyCalibration, AWrongStarHeadingTurnsTheMountsYawByAsMuch) {
  const XqyResult r = solve_xqy(flight_pairs(100, 0.0, 0.0, true, 1), known_heading(0.7 + 0.5 * kDeg));
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_NEAR(angle_between(r.Y, kY), 0.5 * kDeg, 1e-6);
  // Y' = Y Rz(-0.5°): a turn about the body's z.
  EXPECT_NEAR(std::fabs(Eigen::AngleAxisd(kY.transpose() * r.Y).axis().z()), 1.0, 1e-3);
}

// Y for a given X minimises sum ||R_i - X Q_i Y||² (cost summed here, independently of the solver).
TEST(XqyCalibration, YGivenXMinimisesTheFrobeniusCost) {
  const std::vector<RotationPair> pairs = flight_pairs(80, 10 * kDeg, 0.5 * kDeg, false, 4);
  const Eigen::Matrix3d Y = solve_y_given_x(pairs, kX);
  auto cost = [&](const Eigen::Matrix3d& y) {
    double j = 0.0;
    for (const RotationPair& p : pairs) j += (p.R - kX * p.Q * y).squaredNorm();
    return j;
  };
  const double j0 = cost(Y);
  EXPECT_LT(angle_between(Y, kY), 0.2 * kDeg);
  for (double step : {1e-4, 1e-3}) {
    for (int axis = 0; axis < 3; ++axis) {
      for (int sign : {-1, 1}) {
        const Eigen::Vector3d d = sign * step * Eigen::Vector3d::Unit(axis);
        EXPECT_GE(cost(Y * rot(d)), j0 * (1.0 - 1e-12)) << "step " << step << " axis " << axis;
      }
    }
  }
}

}  // namespace
