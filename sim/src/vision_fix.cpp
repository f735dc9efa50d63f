#include "quad/sim/vision_fix.h"

#include <cmath>

namespace quad::sim {

Eigen::Vector3d star_in_body_frd(const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib) {
  return q_ib.conjugate() * (Eigen::Vector3d::Zero() - p_ned);
}

void SimulatedVisionFix::update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool dropout,
                                const FixErrors& errors) {
  if (t + 1e-9 < next_capture_t_) return;
  next_capture_t_ += 1.0 / p_.rate_hz;
  if (!p_.enabled || dropout) return;
  Eigen::Vector3d measured = p_ned;
  for (int i = 0; i < 3; ++i) measured[i] += rng_.normal(p_.noise_m);
  // A decoy at d is seen where the star would be from p - d.
  const Eigen::Vector3d seen_from = errors.decoy_ned ? Eigen::Vector3d(measured - *errors.decoy_ned) : measured;
  const Eigen::Vector3d star_b = star_in_body_frd(seen_from, q_ib).cwiseProduct(errors.scale_frd);
  mavlink::LandingTarget lt;
  lt.time_usec = static_cast<uint64_t>(std::llround(t * 1e6));  // capture time, simulator clock
  lt.frame = mavlink::kFrameBodyFrd;
  lt.x = static_cast<float>(star_b.x());
  lt.y = static_cast<float>(star_b.y());
  lt.z = static_cast<float>(star_b.z());
  lt.distance = static_cast<float>(star_b.norm());
  lt.q[0] = 1.0f;
  lt.position_valid = 1;
  uint8_t buf[mavlink::max_frame_length<mavlink::LandingTarget>()];
  const size_t n = sender_.encode(lt, buf, sizeof buf);
  pending_.emplace_back(t + p_.latency_s + errors.extra_latency_s, std::vector<uint8_t>(buf, buf + n));
}

}  // namespace quad::sim
