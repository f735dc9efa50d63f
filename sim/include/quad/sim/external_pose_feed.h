// The simulated motion-capture system (`external_pose:`; docs/simulator.md): at `rate_hz`, the true pose
// plus Gaussian noise (position per NED axis, attitude per body axis) becomes ATT_POS_MOCAP,
// VISION_POSITION_ESTIMATE or EXTERNAL_POSE_TARGETED with its covariance (sysid 1, compid 197), stamped
// with the capture time on the simulator clock plus `clock_offset_s`, released to the radio `latency_s`
// after capture.
#pragma once

#include <cstdint>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/sim/delayed_frames.h"
#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"

namespace quad::sim {

// Its frames come out through DelayedFrames::release_until().
class SimulatedExternalPose : public DelayedFrames {
 public:
  SimulatedExternalPose(const ExternalPoseParams& params, Rng rng)
      : DelayedFrames(1, mavlink::kCompIdVisualInertialOdometry), p_(params), rng_(std::move(rng)) {}

  // Call every physics step with the truth at time t: captures a pose when one is due (none while
  // `dropout` or when the scenario has no feed).
  void update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool dropout);

 private:
  ExternalPoseParams p_;
  Rng rng_;
  double next_capture_t_ = 0.0;
};

}  // namespace quad::sim
