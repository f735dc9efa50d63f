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
  if (!p_.enabled || dropout || -p_ned.z() < p_.min_height_m) return;
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
  if (p_.attitude_sigma_deg >= 0.0) {
    // The star lies with its tips along north and east: its frame is NED, so q_BS = q_IB*, turned by
    // the station's error (a rotation vector of independent normal components).
    Eigen::Vector3d e;
    for (int i = 0; i < 3; ++i) e[i] = rng_.normal(p_.attitude_sigma_deg * M_PI / 180.0);
    Eigen::Quaterniond q_bs = q_ib.conjugate();
    if (e.norm() > 0.0) q_bs = Eigen::Quaterniond(Eigen::AngleAxisd(e.norm(), e.normalized())) * q_bs;
    q_bs.normalize();
    if (q_bs.w() < 0.0) q_bs.coeffs() *= -1.0;
    lt.q[0] = static_cast<float>(q_bs.w());
    lt.q[1] = static_cast<float>(q_bs.x());
    lt.q[2] = static_cast<float>(q_bs.y());
    lt.q[3] = static_cast<float>(q_bs.z());
  }
  lt.position_valid = 1;
  queue(t + p_.latency_s + errors.extra_latency_s, lt);
}

}  // namespace quad::sim
