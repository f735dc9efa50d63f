// The project's dialect messages of the pose: the covariances of the star fix that travel beside
// LANDING_TARGET (docs/mavlink.md, "Star pose"), and an external pose addressed to one vehicle, for a
// radio channel several vehicles share (docs/mavlink.md, "External pose"). Message ids 43000-43099 are
// the project's range: no dialect of MAVLink's all.xml allocates them. Definition:
// link/mavlink/quad_pose.xml; CRC_EXTRA (92, 20) and the wire order (8-byte, then 4-byte, then 1-byte
// fields) are those mavlink-mappings-gen (tools/node) computes from it.
// Header only, freestanding, in the codec's style (messages.h).
#pragma once

#include <stdint.h>

#include "quad/link/frame.h"
#include "quad/link/wire.h"

namespace quad {
namespace mavlink {

// LANDING_TARGET.type for a printed marker (MAVLink common LANDING_TARGET_TYPE_VISION_FIDUCIAL).
constexpr uint8_t kLandingTargetTypeVisionFiducial = 2;

// LANDING_TARGET_COVARIANCE (43000). Symmetric 3x3 matrices as their upper triangle xx xy xz yy yz zz.
struct LandingTargetCovariance {
  static constexpr uint32_t kId = 43000;
  static constexpr uint8_t kCrcExtra = 92;
  static constexpr uint8_t kBaseLength = 58;
  static constexpr uint8_t kLength = 58;
  static constexpr const char* kName = "LANDING_TARGET_COVARIANCE";
  uint64_t time_usec = 0;               // the LANDING_TARGET's time_usec
  float position_covariance[6] = {};    // m², LANDING_TARGET x y z (body FRD)
  float attitude_covariance[6] = {};    // rad², small rotation of the star frame about the body FRD axes
  uint8_t target_num = 0;               // the LANDING_TARGET's target_num
  uint8_t attitude_valid = 0;           // 1 when LANDING_TARGET.q and attitude_covariance hold a pose
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.position_covariance); io(m.attitude_covariance); io(m.target_num); io(m.attitude_valid);
  }
};
static_assert(wire::count_fields<LandingTargetCovariance>().length == LandingTargetCovariance::kLength,
              "LANDING_TARGET_COVARIANCE layout");

// EXTERNAL_POSE_TARGETED (43001): ATT_POS_MOCAP's pose with the vehicle it is of, and per-axis variances
// instead of the 21-element covariance (53 bytes of payload: 65 bytes a frame, unsigned).
struct ExternalPoseTargeted {
  static constexpr uint32_t kId = 43001;
  static constexpr uint8_t kCrcExtra = 20;
  static constexpr uint8_t kBaseLength = 53;
  static constexpr uint8_t kLength = 53;
  static constexpr const char* kName = "EXTERNAL_POSE_TARGETED";
  uint64_t time_usec = 0;               // capture time, as ATT_POS_MOCAP's
  float x = 0.0f;                       // m, NED
  float y = 0.0f;
  float z = 0.0f;
  float q[4] = {};                      // q_IB, body FRD to NED, w first; q[0] NaN: no attitude
  float position_variance[3] = {};      // m², x y z; [0] NaN: unknown
  float attitude_variance = 0.0f;       // rad² about each body axis; NaN: unknown
  uint8_t target_system = 0;            // the vehicle the pose is of
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.x); io(m.y); io(m.z); io(m.q); io(m.position_variance); io(m.attitude_variance);
    io(m.target_system);
  }
};
static_assert(wire::count_fields<ExternalPoseTargeted>().length == ExternalPoseTargeted::kLength,
              "EXTERNAL_POSE_TARGETED layout");

}  // namespace mavlink
}  // namespace quad
