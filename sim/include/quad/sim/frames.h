// The one place where MuJoCo's frames meet the project's convention.
//
// MuJoCo world: x = North, y = West, z = Up. MuJoCo body: x forward, y left, z up (FLU).
// Project (docs/development.md): inertial NED, body FRD, Hamilton scalar-first q = q_IB.
// Both changes of frame are the same rotation T = Rx(pi) = diag(1, -1, -1), so
//   v_NED = T v_world,   v_FRD = T v_FLU,   R_IB = T R_world_body T,
// and the quaternion of R_IB is q_world_body with its y and z components negated.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace quad::sim {

// World (z-up) vector to NED, and back (T is its own inverse).
inline Eigen::Vector3d world_to_ned(const Eigen::Vector3d& v) { return {v.x(), -v.y(), -v.z()}; }
inline Eigen::Vector3d ned_to_world(const Eigen::Vector3d& v) { return {v.x(), -v.y(), -v.z()}; }

// Body FLU vector (MuJoCo body and sensor frames) to FRD, and back.
inline Eigen::Vector3d flu_to_frd(const Eigen::Vector3d& v) { return {v.x(), -v.y(), -v.z()}; }
inline Eigen::Vector3d frd_to_flu(const Eigen::Vector3d& v) { return {v.x(), -v.y(), -v.z()}; }

// MuJoCo free-joint orientation (w, x, y, z: body FLU to world z-up) to q_IB (body FRD to NED).
inline Eigen::Quaterniond world_body_to_q_ib(const Eigen::Quaterniond& q_wb) {
  return Eigen::Quaterniond(q_wb.w(), q_wb.x(), -q_wb.y(), -q_wb.z());
}
inline Eigen::Quaterniond q_ib_to_world_body(const Eigen::Quaterniond& q_ib) {
  return Eigen::Quaterniond(q_ib.w(), q_ib.x(), -q_ib.y(), -q_ib.z());
}

// Roll, pitch, yaw (ZYX Tait-Bryan, thesis eq. 3.20 with the errata applied) of q_IB.
inline Eigen::Vector3d euler_from_q_ib(const Eigen::Quaterniond& q) {
  const double w = q.w(), x = q.x(), y = q.y(), z = q.z();
  const double roll = std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
  const double s = std::clamp(2.0 * (w * y - x * z), -1.0, 1.0);
  const double yaw = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
  return {roll, std::asin(s), yaw};
}

// q_IB for a yaw angle (rotation about NED down, positive clockwise seen from above).
inline Eigen::Quaterniond q_ib_from_yaw(double yaw) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
}

}  // namespace quad::sim
