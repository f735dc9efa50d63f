#include "quad/sim/external_pose_feed.h"

#include <algorithm>
#include <cmath>

namespace quad::sim {

void SimulatedExternalPose::update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib,
                                   bool dropout) {
  if (!p_.enabled || t + 1e-9 < next_capture_t_) return;
  next_capture_t_ += 1.0 / p_.rate_hz;
  if (dropout) return;
  Eigen::Vector3d p = p_ned;
  for (int i = 0; i < 3; ++i) p[i] += rng_.normal(p_.noise_m);
  const double att_sigma = p_.attitude_noise_deg * M_PI / 180.0;
  Eigen::Vector3d e;
  for (int i = 0; i < 3; ++i) e[i] = rng_.normal(att_sigma);
  Eigen::Quaterniond q = q_ib;
  if (e.norm() > 0.0) q = q * Eigen::Quaterniond(Eigen::AngleAxisd(e.norm(), e.normalized()));  // body axes
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  const uint64_t stamp = static_cast<uint64_t>(std::llround((t + p_.clock_offset_s) * 1e6));
  const float pos_var = static_cast<float>(p_.noise_m * p_.noise_m);
  const float att_var = static_cast<float>(att_sigma * att_sigma);
  const double release = t + p_.latency_s;
  // MAVLink's 21-element pose covariance: the diagonal of x y z roll pitch yaw at 0 6 11 15 18 20.
  float covariance[21] = {};
  for (int i : {0, 6, 11}) covariance[i] = pos_var;
  for (int i : {15, 18, 20}) covariance[i] = att_var;
  switch (p_.message) {
    case ExternalPoseMessage::kAttPosMocap: {
      mavlink::AttPosMocap m;
      m.time_usec = stamp;
      m.q[0] = static_cast<float>(q.w());
      m.q[1] = static_cast<float>(q.x());
      m.q[2] = static_cast<float>(q.y());
      m.q[3] = static_cast<float>(q.z());
      m.x = static_cast<float>(p.x());
      m.y = static_cast<float>(p.y());
      m.z = static_cast<float>(p.z());
      std::copy(covariance, covariance + 21, m.covariance);
      queue(release, m);
      break;
    }
    case ExternalPoseMessage::kVisionPositionEstimate: {
      mavlink::VisionPositionEstimate v;
      v.usec = stamp;
      v.x = static_cast<float>(p.x());
      v.y = static_cast<float>(p.y());
      v.z = static_cast<float>(p.z());
      const Eigen::Matrix3d r = q.toRotationMatrix();  // ZYX angles of body to NED
      v.roll = static_cast<float>(std::atan2(r(2, 1), r(2, 2)));
      v.pitch = static_cast<float>(-std::asin(std::clamp(r(2, 0), -1.0, 1.0)));
      v.yaw = static_cast<float>(std::atan2(r(1, 0), r(0, 0)));
      std::copy(covariance, covariance + 21, v.covariance);
      queue(release, v);
      break;
    }
    case ExternalPoseMessage::kTargeted: {
      mavlink::ExternalPoseTargeted m;
      m.target_system = static_cast<uint8_t>(p_.target_system);
      m.time_usec = stamp;
      m.x = static_cast<float>(p.x());
      m.y = static_cast<float>(p.y());
      m.z = static_cast<float>(p.z());
      m.q[0] = static_cast<float>(q.w());
      m.q[1] = static_cast<float>(q.x());
      m.q[2] = static_cast<float>(q.y());
      m.q[3] = static_cast<float>(q.z());
      for (float& v : m.position_variance) v = pos_var;
      m.attitude_variance = att_var;
      queue(release, m);
      break;
    }
  }
}

}  // namespace quad::sim
