// The EKF's glue in the state estimator (EST_TYPE 1): its parameters, its start from the boot
// calibration, its share of an iteration, the station's fixes and the outputs the estimator reports.
// The ATmega2560's image holds only the thesis pair (kImageHasEkf false): there the outputs are the
// thesis pair's and the EKF's members do not exist.
#include "quad/firmware/state_estimator.h"

#include "quad/firmware/app_checks.h"
#include "quad/firmware/param_fields.h"

namespace quad {
namespace fw {

#if defined(__AVR__)

void StateEstimator::configure_ekf(const Params&) { type_ = EstimatorType::kThesisPair; }
void StateEstimator::start_ekf(uint32_t) {}
void StateEstimator::step_ekf(uint32_t, const Vec3&, const Vec3&, const hal::MagSample*, float, const IterationPlan&, bool) {}
est::FixResult StateEstimator::queue_star(const est::StarFix&) { return est::FixResult::kRejectedInvalid; }
void StateEstimator::attach_covariance(uint32_t, const float*, const float att_cov[6], bool attitude_valid) {
  weigh_star_attitude(attitude_valid ? att_cov : nullptr);
}
bool StateEstimator::converged() const { return calibration_.done() && observer_.initialized(); }
Preflight StateEstimator::preflight() const { return thesis_preflight(); }
EstimatorReport StateEstimator::report() const { return thesis_report(); }
Quat StateEstimator::attitude() const { return observer_.attitude(); }
Vec3 StateEstimator::rate() const { return observer_.rate(); }
Vec3 StateEstimator::position() const { return filter_.position(); }
Vec3 StateEstimator::velocity() const { return filter_.velocity(); }

#else

namespace {

// Still on the ground: the gyro and the specific force's norm within these of rest.
constexpr float kStillRate = 0.1f;        // rad/s
constexpr float kStillForce = 0.5f;       // m/s^2 from g

}  // namespace

void StateEstimator::configure_ekf(const Params& p) {
  const EstimatorType before = type_;
  type_ = p.get(kEstType) >= 0.5f ? EstimatorType::kEkf : EstimatorType::kThesisPair;
  ekf_mag_use_ = p.get(kEstMagUse) >= 0.5f;
  // The hover tracker's assumption (no horizontal specific force but bias while hovering still), off
  // with it (EST_ABIAS_TAU 0: a steady wind's drag is a real force).
  ekf_hover_force_ = p.get(kEstABiasTau) > 0.0f;
  ekf_params_.star_ned = star_ned_;
  load_fields(p, ekf_params_, kEkfFields);
  const float star_att = p.get(kEstStarAtt);
  ekf_params_.star_attitude = star_att >= 1.5f   ? est::StarAttitudeUse::kFull
                              : star_att >= 0.5f ? est::StarAttitudeUse::kHeading
                                                 : est::StarAttitudeUse::kNone;
  // The observer's reference field (learned at the boot calibration, turned by MAG_DECL).
  ekf_params_.mag_ref_ned = observer_.params().mag_ref_ned;
  ekf_.set_params(ekf_params_, kEkfDelayS, ekf_mag_use_ && mag_ref_learned_, ekf_hover_force_);
  ekf_.set_floor(star_ned_.z - ground_height_);
  // Selected on the ground after the calibration: start from the observer's attitude.
  if (type_ == EstimatorType::kEkf && before != type_ && calibration_.done()) start_ekf(filter_.time_us());
}

void StateEstimator::start_ekf(uint32_t t_us) {
  ekf_params_.mag_ref_ned = observer_.params().mag_ref_ned;
  ekf_.set_params(ekf_params_, kEkfDelayS, ekf_mag_use_ && mag_ref_learned_, ekf_hover_force_);
  // The boot calibration's biases are already off the samples the EKF gets: it starts from zero.
  ekf_.reset(observer_.attitude(), Vec3{}, Vec3{}, t_us);
}

void StateEstimator::step_ekf(uint32_t t_us, const Vec3& gyro, const Vec3& accel, const hal::MagSample* mag,
                              float dt, const IterationPlan& plan, bool hovering) {
  if (!ekf_.started()) start_ekf(t_us);
  ekf_.imu(gyro, accel, dt);
  if (mag != nullptr) ekf_.mag(mag->field);
  if (!plan.predict) return;
  const float force_error = absf(norm(accel) - kGravity);
  // Disarmed, or landed or touching down by the land detector (the ground hold's condition).
  const bool still = (!armed_ || on_ground_) && norm(gyro) < kStillRate && force_error < kStillForce;
  // Come to rest below LAND_VIS_HGT above the star, the vehicle stands on the star's floor (as the thesis
  // pair's hold_ground()).
  const bool on_floor = star_ned_.z - ekf_.position().z < star_view_height_;
  ekf_.predict(t_us, still, hovering, on_floor);
}

est::FixResult StateEstimator::queue_star(const est::StarFix& fix) {
  switch (ekf_.queue_fix(fix)) {
    case est::EkfFixResult::kQueued: return est::FixResult::kFused;
    case est::EkfFixResult::kRejectedTooOld: return est::FixResult::kRejectedTooOld;
    case est::EkfFixResult::kRejectedOutOfOrder: return est::FixResult::kRejectedOutOfOrder;
    case est::EkfFixResult::kRejectedBusy: return est::FixResult::kRejectedBusy;
    default: return est::FixResult::kRejectedInvalid;
  }
}

void StateEstimator::attach_covariance(uint32_t capture_us, const float pos_cov[6], const float att_cov[6],
                                       bool attitude_valid) {
  if (ekf_selected()) {
    ekf_.attach_covariance(capture_us, pos_cov, att_cov, attitude_valid);
    return;
  }
  weigh_star_attitude(attitude_valid ? att_cov : nullptr);
}

bool StateEstimator::converged() const {
  if (!calibration_.done() || !observer_.initialized()) return false;
  return !ekf_selected() || ekf_.converged();
}

Preflight StateEstimator::preflight() const {
  if (!ekf_selected()) return thesis_preflight();
  if (!calibration_.done() || !observer_.initialized() || !ekf_.started()) return Preflight::kCalibrating;
  // (The star is out of view on the ground: the EKF's position waits for the first fix in flight.)
  if (ekf_.converged()) return Preflight::kReady;
  return ekf_.filter().tilt_sigma() <= est::kGoodTiltSigma ? Preflight::kVelocity : Preflight::kAttitude;
}

EstimatorReport StateEstimator::report() const {
  if (!ekf_selected() || !ekf_.started()) return thesis_report();
  const est::ErrorStateEkf& f = ekf_.filter();
  const est::EkfTestRatios& k = f.ratios();
  EstimatorReport r;
  r.flags = ekf_.flags();
  if (!sensors_ok_ || imu_clip_.accel_clipped()) r.flags |= est::kEstAccelError;
  r.vel_ratio = k.velocity;
  r.pos_horiz_ratio = k.pos_horiz;
  r.pos_vert_ratio = k.pos_vert;
  r.mag_ratio = maxf(k.heading, k.attitude);
  r.pos_horiz_accuracy = f.horizontal_pos_sigma();
  r.pos_vert_accuracy = f.vertical_pos_sigma();
  return r;
}

Quat StateEstimator::attitude() const { return ekf_selected() && ekf_.started() ? ekf_.attitude() : observer_.attitude(); }
Vec3 StateEstimator::rate() const { return ekf_selected() && ekf_.started() ? ekf_.rate() : observer_.rate(); }
Vec3 StateEstimator::position() const { return ekf_selected() && ekf_.started() ? ekf_.position() : filter_.position(); }
Vec3 StateEstimator::velocity() const { return ekf_selected() && ekf_.started() ? ekf_.velocity() : filter_.velocity(); }

#endif

}  // namespace fw
}  // namespace quad
