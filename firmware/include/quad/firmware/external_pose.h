// External poses: a motion-capture system's or a ground camera's measurement of the vehicle's position
// (and attitude) in NED, from ATT_POS_MOCAP, VISION_POSITION_ESTIMATE or the dialect's
// EXTERNAL_POSE_TARGETED (docs/mavlink.md, "External pose").
//
// The decoders read the fields they need where the received frame holds them (the parser's buffer), so a
// 120-byte message is never copied onto the stack (the ATmega2560's RAM budget counts the peak stack).
// MAVLink's covariance is the 6x6 pose covariance's upper triangle by rows over (x y z roll pitch yaw):
// its position block becomes pos_cov, its roll-pitch-yaw block att_cov (taken as the rotation about the
// body axes: exact level, within the tilt's cosine otherwise); a NaN first element means unknown. An
// image without the EKF (the ATmega2560's) reads the position and time alone: the thesis pair takes no more.
#pragma once

#include <stdint.h>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/math/math.h"

namespace quad {
namespace fw {

struct ExternalPose {
  uint64_t time_usec = 0;  // the sender's stamp (app_fixes.cpp maps it to the vehicle clock)
  Vec3 p_ned;              // m
  Quat q_ib;               // body FRD to NED (valid when has_attitude)
  float pos_cov[6];        // m², NED, upper triangle xx xy xz yy yz zz (valid when has_covariance)
  float att_cov[6];        // rad², about the body axes (valid when has_covariance and has_attitude)
  bool has_attitude = false;
  bool has_covariance = false;
};

// Each fills `pose` from a CRC-checked frame of its message id.
void decode_att_pos_mocap(const mavlink::Frame& frame, ExternalPose* pose);
void decode_vision_position_estimate(const mavlink::Frame& frame, ExternalPose* pose);
// Returns the message's target_system.
uint8_t decode_external_pose_targeted(const mavlink::Frame& frame, ExternalPose* pose);

}  // namespace fw
}  // namespace quad
