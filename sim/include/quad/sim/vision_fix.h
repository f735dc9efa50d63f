// The simulated vision fix, standing in for the vision station when the cameras are not rendered
// (`camera.enabled: false`): at `rate_hz`, the true position plus Gaussian noise becomes a LANDING_TARGET
// (docs/hil-protocol.md: the star, at the NED origin, relative to the vehicle in body FRD; capture time
// on the simulator clock; sysid 1, compid 197), released to the radio `latency_s` after capture.
#pragma once

#include <cstdint>
#include <optional>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "quad/link/mavlink.h"
#include "quad/sim/delayed_frames.h"
#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"

namespace quad::sim {

// The star (NED origin) seen from a vehicle at p_ned with attitude q_ib, in body FRD:
// p_B = R_IB^T (star - p_I), thesis eq. 8.5 inverted (errata sign; the firmware computes
// p_I = star - R_IB p_B).
Eigen::Vector3d star_in_body_frd(const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib);

// What a faulty vision station does to the fix (set by faults.h): it arrives later, comes from a
// mis-calibrated camera (the star in body FRD scaled per axis), or measures a second star-like shape
// taken for the star (at decoy_ned) instead of the star.
struct FixErrors {
  double extra_latency_s = 0.0;
  Eigen::Vector3d scale_frd = Eigen::Vector3d::Ones();
  std::optional<Eigen::Vector3d> decoy_ned;
};

// Its frames come out through DelayedFrames::release_until().
class SimulatedVisionFix : public DelayedFrames {
 public:
  SimulatedVisionFix(const VisionParams& params, Rng rng)
      : DelayedFrames(1, mavlink::kCompIdVisualInertialOdometry), p_(params), rng_(std::move(rng)) {}

  // Call every physics step with the truth at time t: captures a fix when one is due (none while
  // `dropout`, none when disabled), with the station's `errors`.
  void update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool dropout,
              const FixErrors& errors = {});

 private:
  VisionParams p_;
  Rng rng_;
  double next_capture_t_ = 0.0;
};

}  // namespace quad::sim
