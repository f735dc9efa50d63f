// The simulated motion-capture system (`external_pose:`; docs/simulator.md): at `rate_hz`, the true pose
// plus Gaussian noise (position per NED axis, attitude per body axis) becomes ATT_POS_MOCAP,
// VISION_POSITION_ESTIMATE or EXTERNAL_POSE_TARGETED with its covariance (sysid 1, compid 197), stamped
// with the capture time on the simulator clock plus `clock_offset_s`, released to the radio `latency_s`
// after capture.
#pragma once

#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"

namespace quad::sim {

class SimulatedExternalPose {
 public:
  SimulatedExternalPose(const ExternalPoseParams& params, Rng rng) : p_(params), rng_(std::move(rng)) {}

  // Call every physics step with the truth at time t: captures a pose when one is due (none while
  // `dropout` or when the scenario has no feed).
  void update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool dropout);

  // Hands sink(release_time, const uint8_t*, size_t) every frame whose release time is <= t, in order.
  template <class Sink>
  void release_until(double t, Sink&& sink) {
    while (!pending_.empty() && pending_.front().first <= t + 1e-9) {
      const auto& [when, bytes] = pending_.front();
      sink(when, bytes.data(), bytes.size());
      ++released_;
      pending_.pop_front();
    }
  }

  uint64_t released() const { return released_; }

 private:
  template <class Msg>
  void queue(double release_t, const Msg& msg);

  ExternalPoseParams p_;
  Rng rng_;
  mavlink::Sender sender_{1, mavlink::kCompIdVisualInertialOdometry};
  double next_capture_t_ = 0.0;
  std::deque<std::pair<double, std::vector<uint8_t>>> pending_;  // release time, frame
  uint64_t released_ = 0;
};

}  // namespace quad::sim
