#include "quad/firmware/state_estimator.h"

#include "quad/estimation/vector_attitude.h"
#include "quad/firmware/app_checks.h"
#include "quad/firmware/param_fields.h"

namespace quad {
namespace fw {

namespace {

// |det W| below this is not a calibration but a broken matrix (a fitted W is near a rotation-free scale).
constexpr float kMinSoftIronDeterminant = 0.05f;

// The ground hold's pseudo-measurements (docs/estimation.md, "Standing on the ground"): standing still,
// the velocity is zero and the position the one it came to rest at, to well within these; the still
// window before the hold begins.
constexpr float kStillVelocitySigma = 0.01f;  // m/s
constexpr float kStillPositionSigma = 0.01f;  // m
constexpr float kStillTime = 0.5f;            // s

// The star's attitude in the thesis pair (docs/estimation.md, "The star's attitude in the thesis pair"):
// the observer's error assumed at a fix, tilt 0.03 deg and heading 0.06 deg (chosen by the hold's
// standard deviation on flight_plain.yaml), against the station's: the EKF's 0.5 deg without a
// covariance, a 0.1 deg floor under one; at most a fifth of the error per fix.
constexpr est::AttitudeFixWeights kStarAttitudeWeights{0.0005f, 0.001f, 0.0087f, 0.0017f, 0.2f};

// The Earth field with magnetic north along x, expressed in true NED: turned about down by the
// declination (east positive). Out of line: two callers, and two inlined copies of sinf, cosf and six
// products cost AVR flash.
__attribute__((noinline)) Vec3 turn_by_declination(const Vec3& magnetic, float declination) {
  const float c = cosf(declination), s = sinf(declination);
  return Vec3{c * magnetic.x - s * magnetic.y, s * magnetic.x + c * magnetic.y, magnetic.z};
}

}  // namespace

const char* StateEstimator::check(const Params& p) const {
  est::MagCalibration mag_cal;
  load_fields(p, mag_cal, kMagFields);
  // A (nearly) singular soft-iron matrix would flatten the field onto a line or a plane: no heading.
  if (absf(determinant(mag_cal.soft_iron)) < kMinSoftIronDeterminant) return "MAG_SI (singular)";
  const EstimatorType wanted = p.get(kEstType) >= 0.5f ? EstimatorType::kEkf : EstimatorType::kThesisPair;
  if (wanted == EstimatorType::kEkf && !kImageHasEkf) return "EST_TYPE (this image holds only the thesis pair: 0)";
  if (wanted != type_ && armed_) return "EST_TYPE (changed on the ground only)";
  return nullptr;
}

void StateEstimator::configure(const Params& p, float loop_hz) {
  est::ObserverParams op;
  load_fields(p, op, kObserverFields);
  // The Earth field is learned from the boot calibration (magnetic north as x), then turned by the
  // declination so the heading is relative to true north; a new MAG_DECL turns it again.
  mag_declination_ = p.get(kMagDecl);
  op.mag_ref_from_init = !mag_ref_learned_;
  if (mag_ref_learned_) op.mag_ref_ned = turn_by_declination(mag_ref_magnetic_, mag_declination_);
  observer_.set_params(op);
  load_fields(p, mag_cal_, kMagFields);
  mag_cal_is_identity_ = identity_calibration(p);

  est::PositionFilterParams fp;
  fp.process_noise = p.get(kKfQModel) >= 0.5f ? est::ProcessNoise::kWhiteAcceleration : est::ProcessNoise::kThesisDiagonal;
  load_fields(p, fp, kFilterFields);
  fp.z_accel_bias = p.get(kKfZBias) >= 0.5f;
  // The vertical bias learns as fast as the horizontal error states: with the thesis Q (q_p = 1 m^2/s)
  // the fixes credit most of an innovation to the position, and the accelerometer's drift since the
  // boot calibration (0.05 m/s^2 in a minute in the simulated MPU-6000) stays a 5 cm/s velocity error
  // with the slower walk (docs/estimation.md, "From the touchdown"). z then shares x and y's covariance.
  fp.q_bias = fp.q_bias_xy;
  fp.xy_accel_bias = p.get(kKfXYBias) >= 0.5f;
  filter_.set_params(fp);

  load_fields(p, star_ned_, kStarFields);
  Euler mount;
  load_fields(p, mount, kCameraMountFields);
  mount_.configure(mount);

  CalibrationConfig cc;
  load_fields(p, cc, kCalibrationFields);
  calibration_.configure(cc);
  imu_clip_.configure(p.get(kImuGyroRange), p.get(kImuAccRange), p.get(kImuClipHold));
  accel_bias_.configure(p.get(kEstABiasTau), p.get(kEstABiasMax));
  ground_.configure(est::GroundHoldParams{p.get(kEstGndGyro), p.get(kEstGndAcc), kStillTime});
  ground_height_ = p.get(kEstGndHgt);
  star_view_height_ = p.get(kLandVisHgt);
  // The attitude history reaches back 0.3 s at any loop rate, beyond the position filter's 0.25 s.
  history_.set_decimation(AttitudeHistory::decimation_for(loop_hz, 0.3f));
  configure_ekf(p);
  const float star_att = p.get(kEstStarAtt);
  star_attitude_use_ = star_att >= 1.5f ? 2u : star_att >= 0.5f ? 1u : 0u;
  weigh_star_attitude(nullptr);
}

void StateEstimator::weigh_star_attitude(const float* att_cov) {
  star_attitude_gain_ = est::attitude_fix_gain(att_cov, kStarAttitudeWeights);
  if (star_attitude_use_ < 2u) star_attitude_gain_.x = star_attitude_gain_.y = 0.0f;  // the heading alone
}

void StateEstimator::star_attitude(const float q_bs[4], uint32_t capture_us) {
  if (star_attitude_use_ == 0u || ekf_selected()) return;
  const Quat q{q_bs[0], q_bs[1], q_bs[2], q_bs[3]};
  if (!star_attitude_fitted(q_bs) || !usable_attitude(q)) return;
  Quat q_then;
  if (!history_.lookup(capture_us, q_then)) return;
  const Quat q_meas = est::attitude_from_star(q, q_then);
  observer_.correct_attitude(q_meas, q_then, star_attitude_gain_);
}

EstimatorEvent StateEstimator::step(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag, float dt,
                                    const IterationPlan& plan, bool hovering, bool on_ground) {
  sensors_ok_ = is_finite(imu.gyro) && is_finite(imu.accel) && plausible_force(imu.accel);
  on_ground_ = on_ground;
  // Hard and soft iron (thesis eq. 7.5) out before anything reads the field (the default, identity
  // calibration is the field itself).
  hal::MagSample mag_calibrated;
  const hal::MagSample* m = mag;
  if (mag != nullptr && !mag_cal_is_identity_) {
    mag_calibrated.field = mag_cal_.apply(mag->field);
    m = &mag_calibrated;
  }
  EstimatorEvent event = EstimatorEvent::kNone;
  if (!calibration_.done()) {
    calibrate(t_us, imu, m, &event);
    return event;
  }
  // Clipped gyro axes come back held at their last good value (imu_clip.h); the biases come off after.
  const Vec3 gyro = imu_clip_.update(imu, dt);
  if (imu_clip_.burst_started()) event = EstimatorEvent::kClipBurstStarted;
  const Vec3 accel = imu.accel - bias_.bias.accel;
  const bool accel_valid = !imu_clip_.accel_clipped();
  if (plan.frame_work) accel_bias_.update(accel, accel_valid && hovering, plan.frame_dt);
  // The learned bias has z = +0: accel.z - 0.0f is accel.z itself (IEEE: x - (+0) = x, -0 included).
  const Vec3 b = accel_bias_.bias();
  estimate(t_us, gyro - bias_.bias.gyro, Vec3{accel.x - b.x, accel.y - b.y, accel.z}, accel_valid, m, dt, plan,
           on_ground);
  // The EKF learns its own accelerometer bias: the hover tracker's is not taken off.
  if (plan.frame_work) ekf_hovering_ = hovering && accel_valid;
  if (ekf_selected()) step_ekf(t_us, gyro - bias_.bias.gyro, accel, m, dt, plan, ekf_hovering_);
  return event;
}

void StateEstimator::calibrate(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag,
                               EstimatorEvent* event) {
  switch (calibration_.add(t_us, imu.gyro, imu.accel, mag != nullptr ? &mag->field : nullptr)) {
    case BootCalibration::Event::kCollecting:
      return;
    case BootCalibration::Event::kWindowRejected:
      *event = EstimatorEvent::kCalibrationWindowRejected;
      return;
    case BootCalibration::Event::kDone:
      break;
  }
  bias_ = calibration_.result();
  // With the biases removed the mean specific force is -g e_z: level; the heading comes from the
  // magnetometer (TRIAD), or is 0 without one.
  const Vec3 down_force{0.0f, 0.0f, -kGravity};
  if (!bias_.mag_valid || !observer_.initialize(down_force, bias_.mag_mean)) {
    observer_.reset(Quat::identity(), Vec3{});
  } else {
    // initialize() learned the field with magnetic north as x: turn it by the declination and take the
    // TRIAD attitude against the true-north reference.
    mag_ref_magnetic_ = observer_.params().mag_ref_ned;
    mag_ref_learned_ = true;
    est::ObserverParams op = observer_.params();
    op.mag_ref_from_init = false;
    op.mag_ref_ned = turn_by_declination(mag_ref_magnetic_, mag_declination_);
    observer_.set_params(op);
    observer_.initialize(down_force, bias_.mag_mean);
    observer_.reset(observer_.attitude(), Vec3{});
  }
  if (ekf_selected()) start_ekf(t_us);
  *event = EstimatorEvent::kCalibrated;
}

void StateEstimator::estimate(uint32_t t_us, const Vec3& gyro, const Vec3& accel, bool accel_valid,
                              const hal::MagSample* mag, float dt, const IterationPlan& plan, bool on_ground) {
  if (plan.correct) {
    // A magnetometer sample that arrived since the last correction counts if this iteration has none.
    const Vec3* field = mag != nullptr ? &mag->field : (mag_pending_ ? &pending_mag_ : nullptr);
    const Vec3 zero;
    // Without a valid accelerometer the observer gets a zero specific force, which its norm gate refuses:
    // no gravity correction from this sample (the gyro still propagates).
    const Vec3& a = accel_valid ? accel : zero;
    const Vec3& f = field != nullptr ? *field : zero;
    if (plan.multi_rate) {
      observer_.correct(gyro, a, f, field != nullptr, dt, plan.correction_dt);
    } else {
      observer_.update(gyro, a, f, field != nullptr, dt);
    }
    mag_pending_ = false;
  } else {
    // Between corrections the gyro alone carries the attitude, with the last innovation held.
    if (mag != nullptr) {
      pending_mag_ = mag->field;
      mag_pending_ = true;
    }
    observer_.propagate(gyro, dt);
  }
  history_.push(t_us, observer_.attitude());
  // A clipped accelerometer's samples are left out of the mean the prediction takes.
  if (accel_valid) {
    if (accel_count_ == 0) {
      accel_sum_ = accel;  // the first term after a prediction, without three additions to zero
    } else {
      accel_sum_ += accel;
    }
    ++accel_count_;
  }
  if (plan.predict) predict_position(t_us, gyro, on_ground);
}

void StateEstimator::predict_position(uint32_t t_us, const Vec3& gyro, bool on_ground) {
  // thesis eq. 8.7: u = g e_z + R a_B, with a_B the mean specific force over the iterations since the
  // last prediction and R the observer's DCM: this iteration's at 100 Hz; at a faster loop the rotation
  // the last correction started from, the middle of the four samples the mean covers.
  // With no valid sample the last good kinematic acceleration stands in while the clip guard is healthy,
  // then none (the filter coasts on its velocity; the estimator failsafe is already landing).
  Vec3 mean;  // (zero without a valid sample: not still)
  if (accel_count_ > 0) {
    // One sample (a 100 Hz loop) is the sum itself, exactly, without the division and three
    // multiplications (1 100 cycles on the AVR).
    mean = accel_count_ == 1 ? accel_sum_ : accel_sum_ * (1.0f / static_cast<float>(accel_count_));
    last_good_kinematic_accel_ = est::kinematic_acceleration(observer_.dcm(), mean);
  }
  filter_.predict(accel_count_ > 0 || imu_clip_.healthy() ? last_good_kinematic_accel_ : Vec3{}, t_us);
  accel_count_ = 0;  // the next term replaces accel_sum_
  hold_ground(gyro, mean, on_ground);
}

void StateEstimator::hold_ground(const Vec3& gyro, const Vec3& accel, bool on_ground) {
  // The vehicle's centre standing on the star's floor: without fixes (the last part of a landing, on the
  // ground) the estimate is kept above it, so a dead-reckoned descent ends where the vehicle touches down.
  const float ground_z = star_ned_.z - ground_height_;
  filter_.constrain_above_floor(ground_z);
  // (The predictions run at the frame rate whatever the loop rate.) While fixes arrive they hold the
  // estimate: the still time starts when they stop.
  if (!ground_.update(on_ground && !filter_.fixes_arriving(), gyro, accel, 1.0f / FrameSchedule::kRateHz)) {
    // Touched down and still, the still time not yet passed: the velocity is zero already.
    if (ground_.at_rest()) filter_.fuse_zero_velocity(kStillVelocitySigma);
    return;
  }
  if (ground_.started()) {
    // Before any fix the vehicle stands where it took off from: at the star, on its floor (the cameras,
    // close to the floor, see only a patch of it: docs/estimation.md).
    if (!filter_.initialized()) filter_.initialize_at(Vec3{star_ned_.x, star_ned_.y, ground_z});
    // The last known position; come down below LAND_VIS_HGT the vehicle stands on the star's floor, at
    // the ground's height, which the landing's last metre of dead reckoning knows less well.
    Vec3 p = filter_.position();
    if (height_above_star() < star_view_height_) p.z = ground_z;
    ground_.set_reference(p);
  }
  filter_.fuse_still(ground_.reference(), kStillPositionSigma, kStillVelocitySigma);
}

bool StateEstimator::position_from_star(const Vec3& star_body, uint32_t capture_us, Vec3* p_ned) const {
  Quat q_capture;
  if (!history_.lookup(capture_us, q_capture)) return false;
  // thesis eq. 8.5 with the errata sign, the attitude taken at the capture time.
  *p_ned = vehicle_position_from_star(star_ned_, q_capture, star_body);
  return true;
}

bool StateEstimator::healthy() const {
  // An IMU clipping for longer than IMU_CLIP_HOLD leaves the attitude on guessed rates: unhealthy.
  return converged() && imu_clip_.healthy() && is_finite(attitude()) && is_finite(position()) &&
         healthy_speed(velocity());
}

FlashText preflight_text(Preflight p) {
  switch (p) {
    case Preflight::kReady: return QUAD_TEXT("ready");
    case Preflight::kCalibrating: return QUAD_TEXT("calibrating");
    case Preflight::kAttitude: return QUAD_TEXT("attitude var");
    case Preflight::kVelocity: return QUAD_TEXT("velocity var");
    case Preflight::kPosition: return QUAD_TEXT("position var");
  }
  return QUAD_TEXT("?");
}

Preflight StateEstimator::thesis_preflight() const {
  if (!calibration_.done() || !observer_.initialized()) return Preflight::kCalibrating;
  if (!filter_.initialized()) return Preflight::kPosition;
  if (!(maxf(filter_.covariance(0).pp, filter_.covariance(2).pp) <= sqf(kPreflightPositionSigma)))
    return Preflight::kPosition;
  return Preflight::kReady;
}

EstimatorReport StateEstimator::thesis_report() const {
  // The flags as PX4's EKF2 sets them for its aiding sources (DelayedEkfCore::flags()): the observer's
  // attitude once initialised (it has no covariance); position, velocity and predicted position while
  // fixes arrive; velocity, height and constant-position mode while the ground hold holds. No magnetometer
  // or velocity test ratio: the observer's correction and the ground hold are not gated.
  EstimatorReport r;
  if (calibration_.done() && observer_.initialized()) r.flags |= est::kEstAttitude;
  if (!sensors_ok_ || imu_clip_.accel_clipped()) r.flags |= est::kEstAccelError;
  if (!filter_.initialized()) return r;
  const bool aided = filter_.fixes_arriving() && (filter_.health().fused > 0 || filter_.health().resets > 0);
  if (aided) r.flags |= est::kEstPosHorizRel | est::kEstPredPosHorizRel;
  if (aided || ground_.holding()) r.flags |= est::kEstVelocityHoriz | est::kEstVelocityVert | est::kEstPosVertAbs;
  if (ground_.holding()) r.flags |= est::kEstConstPosMode;
  const est::AxisCovariance& h = filter_.covariance(0);
  r.pos_horiz_ratio = filter_.test_ratio_horizontal();
  r.pos_vert_ratio = filter_.test_ratio_vertical();
  r.pos_horiz_accuracy = safe_sqrtf(2.0f * h.pp);
  r.pos_vert_accuracy = safe_sqrtf(filter_.covariance(2).pp);
  return r;
}

Vec3 StateEstimator::position_variance() const {
  return Vec3{filter_.covariance(0).pp, filter_.covariance(1).pp, filter_.covariance(2).pp};
}

Vec3 StateEstimator::velocity_variance() const {
  return Vec3{filter_.covariance(0).vv, filter_.covariance(1).vv, filter_.covariance(2).vv};
}

}  // namespace fw
}  // namespace quad
