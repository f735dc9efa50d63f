// Extended Kalman filter on seed 004's 16-state model (sec. 3.1: attitude quaternion, NED velocity and
// position, gyro bias, accelerometer bias; eq. 3.1-3.34 with the errata), in error-state form: the
// nominal state keeps the unit quaternion q_IB (Hamilton, w first) and the covariance is that of the
// 15-dimensional error
//   dx = (dtheta, dp, dv, db_g, db_a, db_s),   q = q_hat (x) exp(dtheta / 2)   (body-frame attitude error)
// with db_s the station's tilt bias about body x, y (a departure from the seed: the star's attitude is
// fused with it, docs/estimation.md, "The star's attitude")
// (docs/estimation.md, "The EKF", says why and where this departs from the seed). This file is the
// filter proper, at one time; quad/estimation/delayed_ekf.h runs it behind the present so that the
// station's delayed fixes are fused at their capture time.
//
// Usage (the delayed form wraps all of this):
//   quad::est::ErrorStateEkf ekf;
//   ekf.set_params(p);
//   ekf.reset(q0, p0, v0, gyro_bias, accel_bias);
//   ekf.predict(delta_angle, delta_velocity, dt);     // IMU increments over dt (body FRD, raw)
//   ekf.fuse_star(fix);                               // the station's star fix (position, attitude)
//   ekf.fuse_heading(mag_frd); ekf.fuse_position_hold(p); ekf.fuse_zero_velocity();
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace est {

constexpr int kEkfErrorStates = 17;
// Offsets of the blocks of the error state.
enum EkfBlock : uint8_t {
  kEkfTheta = 0, kEkfPos = 3, kEkfVel = 6, kEkfGyroBias = 9, kEkfAccelBias = 12, kEkfStarBias = 15
};

// The nominal state (seed 004 eq. 3.13; the quaternion first, then position before velocity).
struct EkfState {
  Quat q;        // q_IB
  Vec3 p;        // NED position, m
  Vec3 v;        // NED velocity, m/s
  Vec3 gyro_bias;   // rad/s, body FRD
  Vec3 accel_bias;  // m/s^2, body FRD
  Vec3 star_bias;   // rad: the station's attitude turned by this about body x, y from the truth (z unused)
};

enum class StarAttitudeUse : uint8_t { kNone = 0, kHeading = 1, kFull = 2 };

struct EkfParams {
  // Process noise (seed 004 eq. 3.17-3.18 as spectral densities, so that Q scales with the step).
  float gyro_noise = 2e-3f;        // rad/s/sqrt(Hz): angle random walk
  float accel_noise = 0.03f;       // m/s^2/sqrt(Hz): velocity random walk
  float gyro_bias_walk = 5e-5f;    // rad/s^2/sqrt(Hz)
  float accel_bias_walk = 6e-3f;   // m/s^3/sqrt(Hz)
  // Initial standard deviations.
  float tilt_sigma0 = 0.035f;      // rad
  float yaw_sigma0 = 0.2f;         // rad
  float vel_sigma0 = 0.5f;         // m/s
  float pos_sigma0 = 10.0f;        // m (the first fix sets the position: it is never fused against this)
  float gyro_bias_sigma0 = 5e-3f;  // rad/s (after the boot calibration)
  float accel_bias_sigma0 = 0.05f; // m/s^2
  // The station's tilt bias (its stereo calibration and edge points: 0.1 deg on flight_plain.yaml's plain
  // floor, 0.2-0.3 deg on flight.yaml's textured one), a slow random walk (it changes with the star's
  // place in the images). The firmware's EST_SATT_BIAS.
  float star_bias_sigma0 = 0.0087f;  // rad (0.5 deg)
  float star_bias_walk = 2e-5f;      // rad/sqrt(s)
  // Fixes without the station's covariance, and floors added to the station's (it reports its own
  // scatter, not the camera mount's or the star's).
  float fix_sigma = 0.01f;         // m, per axis
  float attitude_sigma = 0.0087f;  // rad, per axis (0.5 deg)
  // The firmware's EST_EVP_NOISE and EST_EVA_NOISE (docs/estimation.md, "The EKF in flight": 1 mm holds
  // steadier than 2 or 5 mm on both flights).
  float fix_sigma_floor = 0.001f;  // m
  float attitude_sigma_floor = 0.0017f;  // rad (0.1 deg)
  float heading_sigma = 0.05f;     // rad, the magnetometer's heading
  float zero_velocity_sigma = 0.02f;  // m/s, while on the ground and still
  float hold_position_sigma = 0.01f;  // m, the position held while on the ground and still
  // A multirotor's specific force has no body x, y component but drag: hovering still, the
  // accelerometer's x, y are its bias (per prediction step: noise, vibration and the hold's motion).
  float hover_force_sigma = 0.1f;     // m/s^2
  // Chi-square gates on the normalised innovation squared of a group (probability 1e-4 of refusing a
  // good measurement): 3 degrees of freedom for a position or attitude fix, 1 for the heading.
  float gate_chi2_3 = 21.1f;
  float gate_chi2_1 = 15.1f;
  Vec3 star_ned;                   // the star's centre in NED, m (its tips along north and east)
  // What the star's attitude corrects: its heading only, or heading and tilt. The station's tilt comes
  // from the depth gradient across the star (0.1 px of disparity per 0.6 deg at 1.5 m), which a small
  // stereo calibration or rendering error biases: fused with the bias states above; its heading does
  // not depend on depth.
  StarAttitudeUse star_attitude = StarAttitudeUse::kHeading;
  Vec3 mag_ref_ned{0.42f, 0.0f, 0.91f};  // Earth field in NED, magnetometer units
};

// The station's fix: the star in body FRD and, when the station fitted the pose, its attitude; or an
// external pose in NED (ned).
struct StarFix {
  uint32_t capture_us = 0;
  Vec3 star_body;         // LANDING_TARGET x y z
  float pos_cov[6];       // m^2, upper triangle xx xy xz yy yz zz (valid when has_covariance)
  Quat q_bs;              // LANDING_TARGET q: the star's axes in body FRD (valid when has_attitude)
  float att_cov[6];       // rad^2 (valid when has_covariance && has_attitude)
  bool has_covariance = false;
  bool has_attitude = false;
  // An external pose (motion capture): star_body holds the body's NED position, pos_cov is in NED and
  // q_bs holds q_IB itself (h = p and h = q instead of the star's R^T (s - p) and q_BS).
  bool ned = false;
};

// Outcome of one measurement group.
enum class EkfFuse : uint8_t { kFused, kRejectedGate, kRejectedInvalid };

// Innovation test ratios of the last fusion of each kind: NIS / gate (above 1: rejected).
struct EkfTestRatios {
  float pos_horiz = 0.0f;  // body x, y of the star fix (horizontal at hover), NIS / chi2(2) gate
  float pos_vert = 0.0f;   // body z
  float attitude = 0.0f;
  float heading = 0.0f;    // magnetometer, or the star's heading when only that is fused
  float velocity = 0.0f;   // zero-velocity update
  float hover_force = 0.0f;  // the hovering specific force's larger axis, NIS / chi2(1) gate
};

class ErrorStateEkf {
 public:
  void set_params(const EkfParams& p) { params_ = p; }
  const EkfParams& params() const { return params_; }
  // Nominal state and the initial diagonal covariance of params().
  void reset(const Quat& q, const Vec3& p, const Vec3& v, const Vec3& gyro_bias, const Vec3& accel_bias);

  // Prediction over dt with the IMU's increments (body FRD, raw: biases still in): delta_angle = integral
  // of the gyro, delta_velocity = integral of the specific force expressed in the body frame at the start
  // of the interval. seed 004 eq. 3.6-3.11 (nominal) and 3.14-3.19 (covariance, error-state Jacobians).
  void predict(const Vec3& delta_angle, const Vec3& delta_velocity, float dt);

  // The star fix: its position (h = R^T (s - p)) and, if present, its attitude, each gated as a group.
  // `position_result` and `attitude_result` (either may be null) say what happened to each.
  void fuse_star(const StarFix& fix, EkfFuse* position_result, EkfFuse* attitude_result);
  // Sets the position from a fix (first fix, or a reset): p = s - R star_body, its covariance from the
  // fix and the attitude's, cross-covariances cleared.
  void initialize_position(const StarFix& fix);
  // Magnetometer heading (seed 004 eq. 3.28-3.34 reduced to the heading: the field rotated into NED
  // with the estimated tilt, its angle against the reference's).
  EkfFuse fuse_heading(const Vec3& mag_frd);
  // Zero velocity (the vehicle stands still on the ground).
  EkfFuse fuse_zero_velocity();
  // The position held while standing still on the ground (where it came to rest; on the star's floor,
  // the floor's height): p = p_hold with hold_position_sigma per axis, not gated.
  EkfFuse fuse_position_hold(const Vec3& p_hold);
  // Hovering still: the mean specific force over a step (body FRD) has x, y = the accelerometer's bias.
  EkfFuse fuse_hover_force(const Vec3& specific_force);
  // Projects the nominal position's down coordinate onto `down` when it is below it (the projection
  // method of constrained Kalman filtering: velocity and covariance unchanged).
  void keep_above(float down);

  const EkfState& state() const { return x_; }
  EkfState& mutable_state() { return x_; }
  float covariance(int i, int j) const { return P_[i][j]; }
  void set_covariance(int i, int j, float value);
  const EkfTestRatios& ratios() const { return ratios_; }
  // Standard deviations for the convergence check and the report.
  float tilt_sigma() const;
  float yaw_sigma() const;
  float horizontal_pos_sigma() const;
  float vertical_pos_sigma() const;
  float velocity_sigma() const;
  bool finite() const;

  // The nominal model and its error-state transition (for the tests: numeric differentiation).
  static void propagate_nominal(EkfState& x, const Vec3& delta_angle, const Vec3& delta_velocity, float dt);
  static void transition(const EkfState& x, const Vec3& delta_angle, const Vec3& delta_velocity, float dt,
                         float F[kEkfErrorStates][kEkfErrorStates]);
  // Applies an error-state correction to the nominal state (q <- q (x) exp(dtheta/2), the rest added).
  static void inject(EkfState& x, const float dx[kEkfErrorStates]);

 private:
  // One scalar measurement (noise variance 1 after whitening) on the accumulated correction dx.
  void scalar_update(const float h[kEkfErrorStates], float innovation, float variance, float dx[kEkfErrorStates]);
  // A group of three whitened measurements: Mahalanobis gate, then sequential scalar updates.
  EkfFuse update3(const float H[3][kEkfErrorStates], const Vec3& innovation, const float cov[6], float* nis,
                  Vec3* per_axis);
  // The star's attitude as a whole (residual rotation vector), or its heading only.
  EkfFuse fuse_star_attitude(const StarFix& fix);
  EkfFuse fuse_star_heading(const StarFix& fix);
  void predict_covariance(const Mat3& a, const Mat3& m, const Mat3& n, float dt);
  void add_process_noise(float dt);
  void symmetrize_and_floor();

  EkfParams params_;
  EkfState x_;
  float P_[kEkfErrorStates][kEkfErrorStates];
  EkfTestRatios ratios_;
};

// Cholesky factor L (lower, packed l00 l10 l11 l20 l21 l22) of a symmetric 3x3 in upper-triangle form;
// false if not positive definite.
bool cholesky3(const float upper[6], float lower[6]);

}  // namespace est
}  // namespace quad
