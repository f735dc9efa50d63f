// Conversions between the flight core's types and Eigen, the independent oracle of the tests.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <random>

#include "quad/math/math.h"

namespace quad_test {

inline Eigen::Vector3d to_eigen(const quad::Vec3& v) { return {v.x, v.y, v.z}; }
inline Eigen::Quaterniond to_eigen(const quad::Quat& q) { return Eigen::Quaterniond(q.w, q.x, q.y, q.z); }
inline Eigen::Matrix3d to_eigen(const quad::Mat3& m) {
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = m.m[i][j];
  return r;
}
inline quad::Vec3 from_eigen(const Eigen::Vector3d& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}
inline quad::Quat from_eigen(const Eigen::Quaterniond& q) {
  return {static_cast<float>(q.w()), static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
}
inline quad::Mat3 from_eigen(const Eigen::Matrix3d& m) {
  quad::Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = static_cast<float>(m(i, j));
  return r;
}

// Uniformly distributed random rotation (Shoemake), as an Eigen quaternion.
inline Eigen::Quaterniond random_rotation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double u1 = u(rng), u2 = u(rng), u3 = u(rng);
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  return Eigen::Quaterniond(b * std::cos(2 * M_PI * u3), a * std::sin(2 * M_PI * u2), a * std::cos(2 * M_PI * u2),
                            b * std::sin(2 * M_PI * u3));
}

inline Eigen::Vector3d random_vector(std::mt19937& rng, double scale) {
  std::normal_distribution<double> n(0.0, scale);
  return {n(rng), n(rng), n(rng)};
}

// Angle between two rotations, radians, sign-invariant.
inline double rotation_distance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.normalized().angularDistance(b.normalized());
}

}  // namespace quad_test
