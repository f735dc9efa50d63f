// The station's fixes as they arrive from the ground link: LANDING_TARGET (the star in the camera rig's
// body frame, turned into the IMU's by the calibrated camera mount) for either estimator, its
// covariances for the EKF, and external poses already in NED (external_pose.h: motion capture, ground
// cameras), which the camera mount does not concern.
#include "quad/firmware/app.h"

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

void FlightApp::star_fix(const mav::LandingTarget& received) {
  ++fixes_received_;
  const uint32_t capture_us = static_cast<uint32_t>(received.time_usec);
  if (received.frame != mav::kFrameBodyFrd || received.position_valid != 1) {
    ++fixes_invalid_;
    logger_.vision_fix(now_us_, nullptr, capture_us, received.q, LogFixResult::kInvalid);
    return;
  }
  // Into the IMU's body frame through the calibrated camera mount (EST_CAM_*), for both estimators.
  mav::LandingTarget msg = received;
  Vec3 star_body{msg.x, msg.y, msg.z};
  estimator_.camera_mount().apply(&star_body, msg.q);
  msg.x = star_body.x;
  msg.y = star_body.y;
  msg.z = star_body.z;
  if (estimator_.ekf_selected()) {
    star_fix_ekf(msg, capture_us);
    return;
  }
  Vec3 p_ned;
  if (!estimator_.position_from_star(star_body, capture_us, &p_ned)) {
    ++fixes_rejected_;
    logger_.vision_fix(now_us_, nullptr, capture_us, msg.q, LogFixResult::kRejectedOld);
    return;
  }
  position_fix_at(p_ned, capture_us, msg.q);
  estimator_.star_attitude(msg.q, capture_us);
}

void FlightApp::star_fix_ekf(const mav::LandingTarget& msg, uint32_t capture_us) {
  // The EKF takes the star in the body frame (and its attitude, q = 1 0 0 0 when none was fitted) and
  // fuses it at its capture time; the station's covariances follow in LANDING_TARGET_COVARIANCE.
  est::StarFix fix;
  fix.capture_us = capture_us;
  fix.star_body = Vec3{msg.x, msg.y, msg.z};
  fix.q_bs = Quat{msg.q[0], msg.q[1], msg.q[2], msg.q[3]};
  fix.has_attitude = star_attitude_fitted(msg.q);
  const est::FixResult r = estimator_.queue_star(fix);
  fix_result(r, false);
  // The log records the fix as the thesis pair would have taken it (NED through the attitude at the
  // capture time; none when no attitude is recorded there) and what the EKF did with it.
  Vec3 p_ned;
  const bool converted = estimator_.position_from_star(fix.star_body, capture_us, &p_ned);
  logger_.vision_fix(now_us_, converted ? &p_ned : nullptr, capture_us, msg.q, log_fix_result(r, false));
}

void FlightApp::star_covariance(const mav::LandingTargetCovariance& msg) {
  estimator_.attach_covariance(static_cast<uint32_t>(msg.time_usec), msg.position_covariance,
                               msg.attitude_covariance, msg.attitude_valid == 1);
}

void FlightApp::external_pose(const ExternalPose& pose) {
  ++fixes_received_;
  // The capture time on the vehicle clock: the sender's stamp, or the arrival minus EXT_POSE_DELAY.
  const float delay_s = params_.get(kExtPoseDelay);
  const uint32_t capture_us = delay_s < 0.0f ? static_cast<uint32_t>(pose.time_usec)
                                             : now_us_ - static_cast<uint32_t>(delay_s * 1e6f);
  if (!estimator_.ekf_selected()) {
    // The thesis pair takes the position, with its own noise (KF_FIX_SIG_XY, KF_FIX_SIG_Z).
    position_fix_at(pose.p_ned, capture_us, nullptr);
    return;
  }
  // The EKF: position and covariance in NED, the attitude as the star's (EST_STAR_ATT).
  est::StarFix fix;
  fix.ned = true;
  fix.capture_us = capture_us;
  fix.star_body = pose.p_ned;
  fix.q_bs = pose.q_ib;
  fix.has_attitude = pose.has_attitude;
  fix.has_covariance = pose.has_covariance;
  for (uint8_t i = 0; i < 6; ++i) {
    fix.pos_cov[i] = pose.pos_cov[i];
    fix.att_cov[i] = pose.att_cov[i];
  }
  const est::FixResult r = estimator_.queue_star(fix);
  fix_result(r, false);
  logger_.vision_fix(now_us_, &pose.p_ned, capture_us, nullptr, log_fix_result(r, false));
}

}  // namespace fw
}  // namespace quad
