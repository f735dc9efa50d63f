#include "quad/estimation/delayed_ekf.h"

namespace quad {
namespace est {

namespace {

int32_t micros_between(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b); }

// Repeated gate rejections of the position that make the next fix a reset (a moved vision origin), and
// the horizontal position sigma beyond which a fix resets the position (lost through an outage).
constexpr uint16_t kResetAfterRejections = 20;
constexpr float kResetPositionSigma = 5.0f;

Quat small_turn(const Vec3& dtheta) {
  const float x2 = 0.25f * norm_sq(dtheta);
  const float s = 0.5f * (1.0f - x2 * (1.0f / 6.0f));
  return Quat{1.0f - 0.5f * x2, dtheta.x * s, dtheta.y * s, dtheta.z * s};
}

}  // namespace

void DelayedEkfCore::set_params(const EkfParams& p, float delay_s, bool use_mag, bool use_hover_force) {
  filter_.set_params(p);
  use_mag_ = use_mag;
  use_hover_force_ = use_hover_force;
  const float d = clampf(delay_s, 0.0f, 10.0f);
  delay_us_ = static_cast<uint32_t>(d * 1e6f + 0.5f);
}

void DelayedEkfCore::reset(const Quat& q, const Vec3& gyro_bias, const Vec3& accel_bias, uint32_t t_us) {
  filter_.reset(q, Vec3{}, Vec3{}, gyro_bias, accel_bias);
  out_ = filter_.state();
  rate_ = Vec3{};
  started_ = true;
  position_initialized_ = false;
  converged_ = false;
  still_ = false;
  fix_fused_ = false;
  rejections_in_a_row_ = 0;
  filter_us_ = t_us;
  last_push_us_ = t_us;
  head_ = 0;
  count_ = 0;
  fix_head_ = 0;
  fix_count_ = 0;
  clear_accumulator();
}

void DelayedEkfCore::clear_accumulator() {
  acc_rotation_ = Quat::identity();
  acc_ = ImuIncrement{};
}

void DelayedEkfCore::imu(const Vec3& gyro, const Vec3& accel, float dt) {
  if (!started_ || !(dt > 0.0f) || !is_finite(gyro) || !is_finite(accel)) return;
  // The increment: the specific force rotated into the frame at the interval's start (the body turns
  // within it), the rates summed (coning neglected at these rates and steps).
  acc_.delta_velocity += rotate(acc_rotation_, accel * dt);
  acc_.delta_angle += gyro * dt;
  acc_rotation_ = normalized(acc_rotation_ * small_turn(gyro * dt));
  acc_.dt += dt;
  // The output carried sample by sample with the filter's biases (seed 004 eq. 3.6-3.9).
  ErrorStateEkf::propagate_nominal(out_, gyro * dt, accel * dt, dt);
  keep_output_above_floor();
  rate_ = gyro - out_.gyro_bias;
}

void DelayedEkfCore::mag(const Vec3& field) {
  if (!started_ || !is_finite(field)) return;
  acc_.mag = field;
  acc_.has_mag = true;
}

void DelayedEkfCore::predict(uint32_t t_us, bool still, bool hovering, bool on_floor) {
  if (!started_) return;
  if (acc_.dt > 0.0f) {
    acc_.t_us = t_us;
    acc_.still = still;
    acc_.on_floor = still && on_floor;
    acc_.hovering = hovering;
    buffer_[head_] = acc_;
    head_ = static_cast<uint16_t>((head_ + 1u) % capacity_);
    if (count_ < capacity_) {
      ++count_;
    } else {
      // Full: the oldest increment is taken by the filter now rather than lost.
      advance(entry(0));
      --count_;
    }
    last_push_us_ = t_us;
  }
  clear_accumulator();
  // The filter takes every increment that ends at or before now - delay.
  while (count_ > 0 && micros_between(entry(0).t_us, t_us - delay_us_) <= 0) {
    advance(entry(0));
    --count_;
  }
  recompute_output();
  if (settled()) converged_ = true;
}

const ImuIncrement& DelayedEkfCore::entry(uint16_t age_from_oldest) const {
  const uint16_t oldest = static_cast<uint16_t>((head_ + capacity_ - count_) % capacity_);
  return buffer_[(oldest + age_from_oldest) % capacity_];
}

void DelayedEkfCore::advance(const ImuIncrement& e) {
  filter_.predict(e.delta_angle, e.delta_velocity, e.dt);
  filter_us_ = e.t_us;
  if (floor_applies()) filter_.keep_above(floor_down_);
  if (e.still) fuse_ground(e);
  still_ = e.still;
  if (e.hovering && use_hover_force_ && filter_.fuse_hover_force(e.delta_velocity * (1.0f / e.dt)) == EkfFuse::kFused)
    ++health_.hover_forces_fused;
  if (e.has_mag && use_mag_) {
    const EkfFuse r = filter_.fuse_heading(e.mag);
    if (r == EkfFuse::kFused) ++health_.headings_fused;
    if (r == EkfFuse::kRejectedGate) ++health_.headings_rejected;
  }
  fuse_due_fixes(e);
}

void DelayedEkfCore::fuse_ground(const ImuIncrement& e) {
  // Where the vehicle came to rest; on the floor its height is known. Held (a measurement, as PX4's EKF2
  // fuses the last known position without aiding) once a fix has set the position: before that the
  // first fix sets it. The position first: its update takes the velocity's correlation with the
  // position, so the zero velocity that follows does not move it along the dead reckoning.
  // While fixes are fused they hold the position (and say where the floor is): the hold starts from
  // where they leave it.
  const bool aided = this->aided(e.t_us);
  if (!still_ || aided) hold_ = filter_.state().p;
  if (e.on_floor) hold_.z = floor_down_;
  if (position_initialized_ && !aided) filter_.fuse_position_hold(hold_);
  filter_.fuse_zero_velocity();
}

bool DelayedEkfCore::aided(uint32_t t_us) const {
  return fix_fused_ && micros_between(t_us, fix_fused_us_) <= static_cast<int32_t>(kAidedWindowUs);
}

bool DelayedEkfCore::floor_applies() const {
  return position_initialized_ && fix_count_ == 0 && !aided(filter_us_);
}

void DelayedEkfCore::keep_output_above_floor() {
  if (floor_applies() && out_.p.z > floor_down_) out_.p.z = floor_down_;
}

void DelayedEkfCore::fuse_due_fixes(const ImuIncrement& e) {
  while (fix_count_ > 0 && micros_between(fixes_[fix_head_].capture_us, e.t_us) <= 0) {
    const StarFix fix = fixes_[fix_head_];
    fix_head_ = static_cast<uint8_t>((fix_head_ + 1u) % kFixQueue);
    --fix_count_;
    fuse_fix(fix, e);
  }
}

void DelayedEkfCore::fuse_fix(StarFix fix, const ImuIncrement& e) {
  // Moved from its capture time to the increment's end (at most one step): the star seen from the body
  // drifts by -w x b - R^T v, the star's attitude in the body turns by -w; an external pose's position
  // moves by v, its q_IB turns by w.
  const EkfState& x = filter_.state();
  const float lag = 1e-6f * static_cast<float>(micros_between(e.t_us, fix.capture_us));
  const Vec3 w = e.delta_angle * (1.0f / e.dt) - x.gyro_bias;
  if (fix.ned) {
    fix.star_body += x.v * lag;
    if (fix.has_attitude) fix.q_bs = fix.q_bs * small_turn(w * lag);
  } else {
    fix.star_body -= (cross(w, fix.star_body) + rotate_inverse(x.q, x.v)) * lag;
    if (fix.has_attitude) fix.q_bs = small_turn(w * -lag) * fix.q_bs;
  }
  const bool lost = filter_.horizontal_pos_sigma() > kResetPositionSigma;
  if (!position_initialized_ || lost || rejections_in_a_row_ >= kResetAfterRejections) {
    // The attitude first (it rotates the fix into NED), then the position set from the fix.
    StarFix attitude_only = fix;
    attitude_only.star_body = Vec3{NAN, NAN, NAN};
    EkfFuse ar = EkfFuse::kRejectedInvalid;
    filter_.fuse_star(attitude_only, nullptr, &ar);
    if (ar == EkfFuse::kFused) ++health_.attitudes_fused;
    filter_.initialize_position(fix);
    position_initialized_ = true;
    rejections_in_a_row_ = 0;
    ++health_.resets;
    fix_fused_ = true;
    fix_fused_us_ = e.t_us;
    return;
  }
  EkfFuse pr = EkfFuse::kRejectedInvalid, ar = EkfFuse::kRejectedInvalid;
  filter_.fuse_star(fix, &pr, &ar);
  if (pr == EkfFuse::kFused) {
    ++health_.positions_fused;
    fix_fused_ = true;
    fix_fused_us_ = e.t_us;
    rejections_in_a_row_ = 0;
  } else if (pr == EkfFuse::kRejectedGate) {
    ++health_.positions_rejected;
    ++rejections_in_a_row_;
  }
  if (ar == EkfFuse::kFused) ++health_.attitudes_fused;
  if (ar == EkfFuse::kRejectedGate) ++health_.attitudes_rejected;
}

void DelayedEkfCore::recompute_output() {
  // The present: the filter's state carried through the increments it has not taken yet.
  out_ = filter_.state();
  for (uint16_t i = 0; i < count_; ++i) {
    const ImuIncrement& e = entry(i);
    ErrorStateEkf::propagate_nominal(out_, e.delta_angle, e.delta_velocity, e.dt);
  }
  keep_output_above_floor();
  if (count_ > 0) {
    const ImuIncrement& newest = entry(static_cast<uint16_t>(count_ - 1u));
    rate_ = newest.delta_angle * (1.0f / newest.dt) - out_.gyro_bias;
  }
}

EkfFixResult DelayedEkfCore::queue_fix(const StarFix& fix) {
  if (!started_ || !is_finite(fix.star_body)) {
    ++health_.fixes_refused;
    return EkfFixResult::kRejectedInvalid;
  }
  if (micros_between(fix.capture_us, filter_us_) <= 0) {
    ++health_.fixes_too_old;
    return EkfFixResult::kRejectedTooOld;
  }
  if (micros_between(fix.capture_us, last_push_us_) > 500000) {
    ++health_.fixes_refused;  // from the future: another clock
    return EkfFixResult::kRejectedInvalid;
  }
  if (fix_count_ > 0) {
    const StarFix& newest = fixes_[(fix_head_ + fix_count_ - 1u) % kFixQueue];
    if (micros_between(fix.capture_us, newest.capture_us) <= 0) {
      ++health_.fixes_refused;
      return EkfFixResult::kRejectedOutOfOrder;
    }
  }
  if (fix_count_ >= kFixQueue) {
    ++health_.fixes_refused;
    return EkfFixResult::kRejectedBusy;
  }
  fixes_[(fix_head_ + fix_count_) % kFixQueue] = fix;
  ++fix_count_;
  return EkfFixResult::kQueued;
}

bool DelayedEkfCore::attach_covariance(uint32_t capture_us, const float pos_cov[6], const float att_cov[6],
                                       bool attitude_valid) {
  for (uint8_t i = 0; i < fix_count_; ++i) {
    StarFix& f = fixes_[(fix_head_ + i) % kFixQueue];
    if (f.capture_us != capture_us) continue;
    for (int k = 0; k < 6; ++k) {
      f.pos_cov[k] = pos_cov[k];
      f.att_cov[k] = att_cov[k];
    }
    f.has_covariance = true;
    f.has_attitude = f.has_attitude && attitude_valid;
    return true;
  }
  return false;
}

bool DelayedEkfCore::settled() const {
  return started_ && filter_.finite() && filter_.tilt_sigma() <= kGoodTiltSigma && filter_.velocity_sigma() <= 0.1f;
}

bool DelayedEkfCore::finite() const {
  return filter_.finite() && is_finite(out_.q) && is_finite(out_.p) && is_finite(out_.v);
}

uint16_t DelayedEkfCore::flags() const {
  if (!started_ || !finite()) return kEstAccelError;
  uint16_t f = 0;
  if (filter_.tilt_sigma() <= kGoodTiltSigma) f |= kEstAttitude;
  const bool aided = this->aided(filter_us_);
  if (aided) f |= kEstPosHorizRel | kEstPredPosHorizRel;
  if (aided || still_) f |= kEstVelocityHoriz | kEstVelocityVert | kEstPosVertAbs;
  if (still_ && !aided) f |= kEstConstPosMode;
  return f;
}

}  // namespace est
}  // namespace quad
