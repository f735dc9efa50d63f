#include "quad/firmware/external_pose.h"

#include "quad/estimation/ekf.h"
#include "quad/firmware/state_estimator.h"

namespace quad {
namespace fw {

namespace {

namespace mav = ::quad::mavlink;
namespace wire = ::quad::mavlink::wire;

// A field of the frame's payload at a wire offset (zero past a truncated end, as decode() reads it).
template <class T>
T field(const mav::Frame& f, size_t offset) {
  return wire::read_at<T>(f.payload, f.payload_length, offset);
}

// Three floats in a row (x y z, roll pitch yaw, three variances).
Vec3 vec3_at(const mav::Frame& f, size_t offset) {
  return Vec3{field<float>(f, offset), field<float>(f, offset + 4), field<float>(f, offset + 8)};
}

// The covariance counts as given when its position variances are positive (a NaN first element, MAVLink's
// "unknown", fails this; so does the all-zero covariance some senders leave in place).
bool variances_given(const float pos_cov[6]) { return pos_cov[0] > 0.0f && pos_cov[3] > 0.0f && pos_cov[5] > 0.0f; }

// MAVLink's pose covariance (21 floats from `offset`, the 6x6 upper triangle by rows over x y z roll
// pitch yaw): the position block (row-major indices 0 1 2 6 7 11) and the attitude block (15 .. 20).
void covariance_at(const mav::Frame& f, size_t offset, ExternalPose* pose) {
  // (Indices as code, not a table: a table of constants would take the AVR's RAM.)
  for (uint8_t i = 0; i < 6; ++i) {
    const uint8_t row = i < 3 ? 0 : i < 5 ? 1 : 2;
    const uint8_t index = row == 0 ? i : row == 1 ? static_cast<uint8_t>(i + 3) : 11;
    pose->pos_cov[i] = field<float>(f, offset + 4u * index);
    pose->att_cov[i] = field<float>(f, offset + 4u * (15u + i));
  }
  pose->has_covariance = variances_given(pose->pos_cov);
}

void set_attitude(const Quat& q, ExternalPose* pose) {
  pose->has_attitude = usable_attitude(q);
  pose->q_ib = pose->has_attitude ? normalized(q) : Quat::identity();
}

}  // namespace

void decode_att_pos_mocap(const mav::Frame& f, ExternalPose* pose) {
  typedef mav::AttPosMocap M;
  pose->time_usec = field<uint64_t>(f, wire::field_offset<M>(0));
  pose->p_ned = vec3_at(f, wire::field_offset<M>(2));
  if (!kImageHasEkf) return;  // the thesis pair takes the position alone (AVR flash)
  const size_t q = wire::field_offset<M>(1);
  set_attitude(Quat{field<float>(f, q), field<float>(f, q + 4), field<float>(f, q + 8), field<float>(f, q + 12)},
               pose);
  covariance_at(f, wire::field_offset<M>(5), pose);
}

void decode_vision_position_estimate(const mav::Frame& f, ExternalPose* pose) {
  typedef mav::VisionPositionEstimate M;
  pose->time_usec = field<uint64_t>(f, wire::field_offset<M>(0));
  pose->p_ned = vec3_at(f, wire::field_offset<M>(1));
  if (!kImageHasEkf) return;
  const Vec3 rpy = vec3_at(f, wire::field_offset<M>(4));  // roll pitch yaw (ZYX)
  if (is_finite(rpy)) {
    set_attitude(from_euler(Euler{rpy.x, rpy.y, rpy.z}), pose);
  } else {
    pose->has_attitude = false;
  }
  covariance_at(f, wire::field_offset<M>(7), pose);
}

uint8_t decode_external_pose_targeted(const mav::Frame& f, ExternalPose* pose) {
  typedef mav::ExternalPoseTargeted M;
  pose->time_usec = field<uint64_t>(f, wire::field_offset<M>(0));
  pose->p_ned = vec3_at(f, wire::field_offset<M>(1));
  const uint8_t target = field<uint8_t>(f, wire::field_offset<M>(7));
  if (!kImageHasEkf) return target;
  const size_t q = wire::field_offset<M>(4);
  set_attitude(Quat{field<float>(f, q), field<float>(f, q + 4), field<float>(f, q + 8), field<float>(f, q + 12)},
               pose);
  // Per-axis variances: diagonal blocks; an unknown attitude variance is the EKF's default.
  const Vec3 var = vec3_at(f, wire::field_offset<M>(5));
  float att_var = field<float>(f, wire::field_offset<M>(6));
  if (!(att_var >= 0.0f)) att_var = est::EkfParams().attitude_sigma * est::EkfParams().attitude_sigma;
  const float pos[6] = {var.x, 0.0f, 0.0f, var.y, 0.0f, var.z};
  const float att[6] = {att_var, 0.0f, 0.0f, att_var, 0.0f, att_var};
  for (uint8_t i = 0; i < 6; ++i) {
    pose->pos_cov[i] = pos[i];
    pose->att_cov[i] = att[i];
  }
  pose->has_covariance = variances_given(pose->pos_cov);
  return target;
}

}  // namespace fw
}  // namespace quad
