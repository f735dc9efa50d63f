// The vehicle's state estimate from the IMU, the magnetometer and the vision fixes: the boot calibration
// hand-off, the IMU clip guard, the conditioned observer (attitude, gyro bias; thesis ch. 4), the
// per-axis Kalman filter (position, velocity; thesis eq. 8.7-8.12) with the fusion of delayed fixes at
// their capture time, the in-flight accelerometer bias learned while hovering, and the ground hold (zero
// velocity and the last known position fused while the vehicle stands still on the ground).
//
// It knows no MAVLink and no time source: the application hands it samples, the iteration's plan
// (frame_schedule.h) and the parameters, and reports what it returns. This is where another estimator
// would be chosen: an image compiles in the estimators it can hold, and a parameter picks one of them
// behind this interface (no virtual dispatch).
#pragma once

#include <stdint.h>

#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/ground_hold.h"
#include "quad/estimation/hover_accel_bias.h"
#include "quad/estimation/position_filter.h"
#include "quad/firmware/calibration.h"
#include "quad/firmware/frame_schedule.h"
#include "quad/firmware/imu_clip.h"
#include "quad/firmware/params.h"
#include "quad/firmware/vision.h"
#include "quad/hal/hal.h"
#include "quad/math/math.h"

namespace quad {
namespace fw {

// The filter's history covers 250 ms of vision delay at the 100 Hz prediction rate.
constexpr int kPositionHistory = est::history_length(100);

// The estimators an image holds, chosen by EST_TYPE: the thesis pair everywhere; the EKF (seed 004)
// where there is room for it (not the ATmega2560: docs/estimation.md, "The EKF on the AVR").
enum class EstimatorType : uint8_t { kThesisPair = 0, kEkf = 1 };
#if defined(__AVR__)
constexpr bool kImageHasEkf = false;
#else
constexpr bool kImageHasEkf = true;
#endif
// How far behind now the EKF runs: the largest fix delay it fuses (the station's is about 40 ms).
constexpr float kEkfDelayS = 0.1f;

// What an estimator iteration has to report to the operator.
enum class EstimatorEvent : uint8_t {
  kNone,
  kCalibrationWindowRejected,  // calibration_rejection() says why
  kCalibrated,
  kClipBurstStarted,           // the IMU began a run of clipped samples
};

// The estimator's health (ESTIMATOR_STATUS, the flight log's estimator_status): the last fusions'
// innovation test ratios (NIS over the gate), the position's 1-sigma accuracies and the flags
// (est::EstimatorFlag, MAVLink's ESTIMATOR_STATUS_FLAGS). docs/estimation.md, "Health report".
struct EstimatorReport {
  uint16_t flags = 0;
  float vel_ratio = 0.0f;
  float pos_horiz_ratio = 0.0f;
  float pos_vert_ratio = 0.0f;
  float mag_ratio = 0.0f;  // the heading: the magnetometer's or the star's (and the star's attitude)
  float pos_horiz_accuracy = 0.0f;
  float pos_vert_accuracy = 0.0f;
};

// Why arming waits (the pre-arm check): the first unmet condition.
enum class Preflight : uint8_t { kReady, kCalibrating, kAttitude, kVelocity, kPosition };
FlashText preflight_text(Preflight p);

// The pre-arm threshold (1 sigma, per axis) of the thesis pair's position: on the ground the hold brings
// it to about 0.01 m; it is above the thesis Q's steady state with fixes at 30 Hz (0.15 m horizontally at
// 100 Hz; vertically 0.23-0.31 m over a fix period at 200 Hz, ESTIMATOR_STATUS pos_vert_accuracy in the
// 200 Hz PIL hover), so a vehicle that stands in view of the star can arm too. Its velocity variance is not checked: with table 8.1's
// Q (q_p = 1 m^2/s) the fixes leave the velocity's sigma at about 1 m/s whatever the vehicle does. The
// EKF's thresholds are its own (DelayedEkfCore::converged).
constexpr float kPreflightPositionSigma = 0.5f;  // m

class StateEstimator {
 public:
  // The name of the offending parameter when p cannot be applied, else nullptr (nothing changed).
  const char* check(const Params& p) const;
  // Takes p (which check() accepted); loop_hz sets how far back the attitude history reaches.
  void configure(const Params& p, float loop_hz);

  // Starts the boot calibration over (keep the vehicle still).
  void restart_calibration() { calibration_.restart(); }
  // Armed or not: EST_TYPE changes only on the ground; the EKF fuses zero velocity while disarmed (or on
  // the ground by the land detector) and still.
  void set_armed(bool armed) { armed_ = armed; }
  EstimatorType type() const { return type_; }
  bool ekf_selected() const { return kImageHasEkf && type_ == EstimatorType::kEkf; }

  // One iteration at t_us: the sample, its period dt and what the iteration runs. hovering: the vehicle
  // hovers still in AUTO (its horizontal specific force is the accelerometer's bias), read only in the
  // frame-rate work's iteration. on_ground: disarmed, or landed or touching down by the land detector
  // (read with the prediction: the ground hold).
  EstimatorEvent step(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag, float dt,
                      const IterationPlan& plan, bool hovering, bool on_ground);

  // Vision fixes (thesis eq. 8.5 with the errata sign): the vehicle's NED position from the star seen in
  // body FRD at capture_us; false when the attitude at that time is no longer (or not yet) recorded.
  bool position_from_star(const Vec3& star_body, uint32_t capture_us, Vec3* p_ned) const;
  // The star's attitude (LANDING_TARGET q, q_BS in the IMU's body frame) into the thesis pair's observer
  // at the capture time (EST_STAR_ATT 1: heading, 2: heading and tilt; docs/estimation.md, "The star's
  // attitude in the thesis pair"), weighed by the last attitude covariance attach_covariance() gave.
  // Nothing with the EKF selected (it takes the attitude with the fix), EST_STAR_ATT 0, q = 1 0 0 0 (no
  // attitude in the fix), or no attitude recorded at the capture time.
  void star_attitude(const float q_bs[4], uint32_t capture_us);
  // The fusion at the capture time, all at once or (queue, then two advance steps) over two frames.
  est::FixResult fuse_fix(const Vec3& p_ned, uint32_t capture_us) { return filter_.fuse_position(p_ned, capture_us); }
  est::FixResult queue_fix(const Vec3& p_ned, uint32_t capture_us) { return filter_.queue_fix(p_ned, capture_us); }
  est::FixResult advance_fix() { return filter_.advance_fix(); }
  bool fix_in_progress() const { return filter_.fix_in_progress(); }
  uint32_t filter_resets() const { return filter_.health().resets; }
  // The EKF's fixes (star in body FRD, its attitude, its covariances), fused at the capture time.
  est::FixResult queue_star(const est::StarFix& fix);
  void attach_covariance(uint32_t capture_us, const float pos_cov[6], const float att_cov[6], bool attitude_valid);

  bool calibrated() const { return calibration_.done(); }
  est::CalibrationStatus calibration_rejection() const { return calibration_.rejection(); }
  bool mag_valid() const { return bias_.mag_valid; }
  // The sample was finite and its specific force plausible.
  bool sensors_ok() const { return sensors_ok_; }
  bool converged() const;
  // The pre-arm check: converged() and the variances under the thresholds (the thesis pair's position
  // filter initialised, by the ground hold or a fix, with its position variance under
  // kPreflightPositionSigma; the EKF's tilt and velocity, DelayedEkfCore::converged()).
  Preflight preflight() const;
  EstimatorReport report() const;
  // Converged, finite, not diverged, and not flying on held gyro rates longer than IMU_CLIP_HOLD.
  bool healthy() const;
  const ImuClipGuard& imu_clip() const { return imu_clip_; }

  Quat attitude() const;
  Vec3 rate() const;
  Vec3 position() const;
  Vec3 velocity() const;
  Vec3 accel_bias() const { return accel_bias_.bias(); }
  // The observer's gyro bias (rad/s, FRD); the position filter's acceleration bias states (m/s^2, NED;
  // zero on axes without one) and the diagonal of its covariance (the flight log).
  Vec3 gyro_bias() const { return observer_.gyro_bias(); }
  Vec3 filter_accel_bias() const { return filter_.accel_bias(); }
  Vec3 position_variance() const;
  Vec3 velocity_variance() const;
  // On the ground and still: the filter holds zero velocity and the last known position.
  bool holding_ground() const { return ground_.holding(); }
  // The camera rig's mount (EST_CAM_*): the application turns every fix into the IMU's body frame with it.
  const CameraMount& camera_mount() const { return mount_; }
  // The estimate's height above the star (VIS_STAR_D, the floor it lies on), m.
  float height_above_star() const { return star_ned_.z - filter_.position().z; }

 private:
  void calibrate(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag, EstimatorEvent* event);
  // accel_valid false: the accelerometer clipped (no gravity correction, the held kinematic acceleration).
  void estimate(uint32_t t_us, const Vec3& gyro, const Vec3& accel, bool accel_valid, const hal::MagSample* mag,
                float dt, const IterationPlan& plan, bool on_ground);
  // The rotation-corrected mean specific force since the last prediction, then the prediction (eq. 8.7),
  // then the ground hold.
  void predict_position(uint32_t t_us, const Vec3& gyro, bool on_ground);
  // Standing still on the ground: zero velocity and the last known position into the filter (before the
  // first fix, the ground's position: at the star, EST_GND_HGT above its floor; below LAND_VIS_HGT the
  // ground's height).
  void hold_ground(const Vec3& gyro, const Vec3& accel, bool on_ground);
  // The EKF's share of an iteration (the observer still runs: the switch back needs its attitude).
  void step_ekf(uint32_t t_us, const Vec3& gyro, const Vec3& accel, const hal::MagSample* mag, float dt,
                const IterationPlan& plan, bool hovering);
  void start_ekf(uint32_t t_us);
  void configure_ekf(const Params& p);
  // The star attitude's gains from a fix's attitude covariance (null: none came with it).
  void weigh_star_attitude(const float* att_cov);
  Preflight thesis_preflight() const;
  EstimatorReport thesis_report() const;

  BootCalibration calibration_;
  CalibrationResult bias_;
  est::ConditionedObserver observer_;
  est::PositionFilter<kPositionHistory> filter_;
  AttitudeHistory history_;
  ImuClipGuard imu_clip_;
  est::HoverAccelBias accel_bias_;  // the accelerometer's in-flight x/y bias drift
  est::GroundHold ground_;          // still on the ground: EST_GND_GYRO, EST_GND_ACC
  float ground_height_ = 0.0f;      // EST_GND_HGT: the reference point's height above the floor, standing
  float star_view_height_ = 0.0f;   // LAND_VIS_HGT: below it a vehicle that comes to rest is on the floor
  Vec3 accel_sum_;                  // body specific force summed between predictions (valid samples)
  uint8_t accel_count_ = 0;
  Vec3 last_good_kinematic_accel_;  // stands in for a clipped accelerometer's (eq. 8.7)
  Vec3 pending_mag_;                // a magnetometer sample that arrived between two corrections
  bool mag_pending_ = false;
  bool sensors_ok_ = false;
  Vec3 star_ned_;                   // VIS_STAR_*
  CameraMount mount_;               // EST_CAM_*
  est::MagCalibration mag_cal_;     // MAG_OFS_*, MAG_SI_*
  bool mag_cal_is_identity_ = true; // MAG_OFS zero, MAG_SI the identity: eq. 7.5 is the field itself
  float mag_declination_ = 0.0f;    // MAG_DECL
  Vec3 mag_ref_magnetic_;           // Earth field learned at boot, magnetic north along x
  bool mag_ref_learned_ = false;
  // The thesis pair's gains for the star's attitude per body axis (x, y zero for the heading alone),
  // from the last LANDING_TARGET_COVARIANCE (the station sends it after its LANDING_TARGET).
  Vec3 star_attitude_gain_;
  uint8_t star_attitude_use_ = 0;   // EST_STAR_ATT
  EstimatorType type_ = EstimatorType::kThesisPair;
  bool armed_ = false;
  bool ekf_mag_use_ = true;
  bool ekf_hover_force_ = true;  // EST_ABIAS_TAU > 0
  bool ekf_hovering_ = false;    // the frame-rate work's hovering flag, held between frames
  bool on_ground_ = false;       // the step's on_ground: the EKF fuses zero velocity there when still
#if !defined(__AVR__)
  est::DelayedEkf<kPositionHistory> ekf_;
  est::EkfParams ekf_params_;
#endif
};

}  // namespace fw
}  // namespace quad
