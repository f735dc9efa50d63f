#include "quad/estimation/position_filter.h"

#include "quad/math/float_bits.h"

#include <string.h>  // memcmp

namespace quad {
namespace est {

namespace {

constexpr float kMaxStep = 0.5f;        // s: a longer predict step is a gap, not a sample period
constexpr float kFoldThreshold = 1.0f;  // m: fold the accumulated correction into the history beyond this
constexpr float kMaxKeptSpeed = 10.0f;  // m/s: a faster velocity estimate is not kept through a reset

// Signed microseconds a - b on the wrapping 32-bit vehicle clock, in seconds.
float seconds_between(uint32_t a, uint32_t b) { return static_cast<float>(static_cast<int32_t>(a - b)) * 1e-6f; }
// Signed microseconds a - b, for comparisons that need no float (a conversion and a multiplication
// fewer on the AVR).
int32_t micros_between(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b); }

// Q(T) = int_0^T Phi(t) diag(qp, qv, qb) Phi(t)^T dt for Phi(t) = [[1, t, -t^2/2], [0, 1, -t], [0, 0, 1]]:
// the exact discretisation of the continuous process whose Euler form is thesis eq. 8.12. This is its
// qp, qv part (the same for every covariance class), with t2 = t^2 and h = t^2/2 given; add_bias_noise()
// adds the qb part.
AxisCovariance process_noise(float t, float t2, float h, float qp, float qv) {
  AxisCovariance q;
  q.pp = qp * t + qv * (t2 * t) * (1.0f / 3.0f);
  q.pv = qv * h;
  q.vv = qv * t;
  return q;
}

// The qb part of Q(T) (eq. 8.12 extended by the bias random walk), added to q. The powers qb t^n are
// formed each from the last (seven multiplications instead of twelve; float rounding only).
void add_bias_noise(AxisCovariance& q, float t, float qb) {
  if (!(qb > 0.0f)) return;
  const float b1 = qb * t, b2 = b1 * t, b3 = b2 * t, b4 = b3 * t, b3_3 = b3 * (1.0f / 3.0f);
  q.pp += b4 * t * (1.0f / 20.0f);  // qb t^5 / 20
  q.pv += 0.125f * b4;              // qb t^4 / 8
  q.vv += b3_3;                     // qb t^3 / 3
  q.pb = -0.5f * b3_3;              // -qb t^3 / 6
  q.vb = -0.5f * b2;                // -qb t^2 / 2
  q.bb = b1;                        // qb t
}

// P <- Phi(T) P Phi(T)^T + Q(T)   (thesis eq. 8.11a, F of eq. 8.10 extended by the bias column); h = T^2/2.
void propagate_covariance(AxisCovariance& p, float t, float h, bool bias, const AxisCovariance& q) {
  if (!bias) {
    // P'_pp = pp + 2 T pv + T^2 vv = pp + T (pv + n) with n = pv + T vv, the P'_pv before its Q term (one
    // addition fewer than forming 2 pv; float rounding only).
    const float n = p.pv + t * p.vv;
    p.pp += t * (p.pv + n) + q.pp;
    p.pv = n + q.pv;
    p.vv += q.vv;
    return;
  }
  // A = Phi P has rows r0, r1 and P's last row; P' = A Phi^T. Of A only r01, r02 and r12 are formed:
  // P'_00 = r00 + T r01 - h r02 = pp + T (pv + r01) - h (pb + r02) and P'_11 = r11 - T r12 = vv - T (vb + r12)
  // fold r00 and r11 in (9 multiplications instead of 12; float rounding only).
  const float r01 = p.pv + t * p.vv - h * p.vb, r02 = p.pb + t * p.vb - h * p.bb, r12 = p.vb - t * p.bb;
  p.pp += t * (p.pv + r01) - h * (p.pb + r02) + q.pp;
  p.pv = r01 - t * r02 + q.pv;
  p.pb = r02 + q.pb;
  p.vv -= t * (p.vb + r12) - q.vv;
  p.vb = r12 + q.vb;
  p.bb += q.bb;
}

}  // namespace

Vec3 kinematic_acceleration(const Quat& q_ib, const Vec3& specific_force_frd) {
  // thesis eq. 8.7: u = g e_z + R a_B
  return rotate(q_ib, specific_force_frd) + Vec3{0.0f, 0.0f, kGravity};
}

Vec3 kinematic_acceleration(const Mat3& r_ib, const Vec3& specific_force_frd) {
  // thesis eq. 8.7
  Vec3 u = r_ib * specific_force_frd;
  u.z += kGravity;
  return u;
}

PositionFilterCore::PositionFilterCore(HistoryEntry* storage, uint16_t capacity, const PositionFilterParams& params)
    : params_(params), history_(storage), capacity_(capacity) {  // (a copy: smaller than the defaults' stores)
  set_params(params);
}

void PositionFilterCore::set_params(const PositionFilterParams& params) {
  drop_fix();  // its D h and 1 / S belong to the old model
  params_ = params;
  q_step_us_ = 0;  // the cached Q(T) belongs to the old parameters (no step is 0 us)
  if (z_shares_xy_covariance_) {  // z gets its own copy back before the sharing is re-decided
    p_[1] = p_[0];
    for (int j = 0; j < 3; ++j) gain_[1][j] = gain_[0][j];
  }
  for (int c = 0; c < 2; ++c) {
    // A bias state switched on in flight starts uncertain, so that it learns; one switched off is gone.
    if (class_has_bias(c)) {
      if (initialized_ && p_[c].bb == 0.0f) p_[c].bb = sqf(params.bias_sigma0);
      continue;
    }
    p_[c].pb = p_[c].vb = p_[c].bb = 0.0f;
  }
  for (int i = 0; i < 3; ++i) {
    if (has_bias(i)) continue;
    x_[i].b = 0.0f;
    correction_[i].b = 0.0f;
    old_epoch_correction_[i].b = 0.0f;
  }
  update_class_sharing();
}

// z shares the horizontal covariance when its model and fix noise are the same (the same bias choice,
// equal sigma) and its covariance is bit-identical now: the same operations then keep it identical, so
// computing it once is exact, not an approximation.
void PositionFilterCore::update_class_sharing() {
  // The covariances compared as bits (one memcmp instead of six float comparisons: smaller code, and
  // exactly the "identical numbers" the sharing needs; AxisCovariance is six floats, no padding).
  z_shares_xy_covariance_ = qb(0) == qb(1) && params_.z_accel_bias == params_.xy_accel_bias &&
                            params_.fix_sigma_xy == params_.fix_sigma_z &&
                            memcmp(&p_[0], &p_[1], sizeof(AxisCovariance)) == 0;
}

void PositionFilterCore::reset(const Vec3& p_ned, const Vec3& v_ned, uint32_t t_us) {
  drop_fix();
  for (int i = 0; i < 3; ++i) {
    x_[i] = AxisState{p_ned[i], v_ned[i], 0.0f};
    correction_[i] = Correction{};
  }
  for (int c = 0; c < 2; ++c) {
    p_[c] = AxisCovariance{};
    p_[c].pp = sqf(c == 1 ? params_.fix_sigma_z : params_.fix_sigma_xy);
    p_[c].vv = sqf(params_.vel_sigma0);
    if (class_has_bias(c)) p_[c].bb = sqf(params_.bias_sigma0);
  }
  update_class_sharing();
  t_us_ = t_us;
  clock_started_ = true;
  initialized_ = true;
  have_fix_ = false;
  have_still_ = false;
  consecutive_rejections_ = 0;
  clear_history();
  push_history();
}

float PositionFilterCore::last_gain_p(int axis) const {
  const int c = covariance_class(axis);
  const float* k = gain_[c];
  const float s = fix_stage_ == kFixGated ? fix_inv_s_[c] : 1.0f;  // (gated: gain_ holds D h)
  return s * (k[0] - gain_tau_ * (k[1] + 0.5f * gain_tau_ * k[2]));  // K = Phi(-tau) (D h / S)
}

float PositionFilterCore::last_gain_v(int axis) const {
  const int c = covariance_class(axis);
  const float* k = gain_[c];
  const float s = fix_stage_ == kFixGated ? fix_inv_s_[c] : 1.0f;
  return s * (k[1] + gain_tau_ * k[2]);
}

void PositionFilterCore::drop_fix() {
  if (fix_stage_ == kFixIdle) return;
  fix_stage_ = kFixIdle;
  ++health_.dropped_pending;
}

void PositionFilterCore::clear_history() {
  head_ = 0;
  count_ = 0;
  old_epoch_left_ = 0;  // (no entry, no old epoch)
}

float PositionFilterCore::correction_position(int axis, float dt) const {
  const Correction& c = correction_[axis];
  if (!has_bias(axis)) return c.p + dt * c.v;  // c.b is zero
  return c.p + dt * (c.v - 0.5f * dt * c.b);
}

// History entries hold p - (accumulated correction carried to their time); see the header. The
// correction is kept at now, so that is its position.
void PositionFilterCore::push_history() {
  HistoryEntry& e = history_[head_];
  e.t_us = t_us_;
  for (int i = 0; i < 3; ++i) e.p[i] = x_[i].p - correction_[i].p;
  head_ = static_cast<uint16_t>(head_ + 1 == capacity_ ? 0 : head_ + 1);
  if (count_ < capacity_) {
    ++count_;
  } else if (old_epoch_left_ > 0) {
    --old_epoch_left_;  // the oldest entry, overwritten, was of the old epoch
  }
  // Once the last fused fix is older than the whole history, no fix can be out of order with it; forget
  // it before the 32-bit clock difference could wrap (after 35 min without fixes).
  if (have_fix_) {
    uint16_t k = static_cast<uint16_t>(head_ + capacity_ - count_);
    if (k >= capacity_) k = static_cast<uint16_t>(k - capacity_);
    const HistoryEntry& oldest = history_[k];
    if (micros_between(oldest.t_us, last_fix_us_) > 0) have_fix_ = false;
  }
  if (have_still_ || have_offered_) {
    uint16_t k = static_cast<uint16_t>(head_ + capacity_ - count_);
    if (k >= capacity_) k = static_cast<uint16_t>(k - capacity_);
    const uint32_t oldest = history_[k].t_us;
    if (micros_between(oldest, still_us_) > 0) have_still_ = false;
    if (micros_between(oldest, offered_us_) > 0) have_offered_ = false;
  }
}

// Starts an epoch instead of adding the accumulated correction into every history entry (68 000 cycles on
// the AVR for 26 entries): it becomes the old epoch's correction, frozen at the newest entry's time (now),
// which the entries in the buffer now get on lookup until they have left it, and the correction restarts
// at zero, so that neither it nor the stored values grow without bound. Rare (beyond a metre); a second
// fold while an old epoch is left first adds its correction into its entries (O(those entries)), after
// which every entry is of the current epoch.
void PositionFilterCore::fold_correction() {
  if (old_epoch_left_ > 0) fold_old_epoch();
  // The newest entry is at now (every predict, reset and initialisation pushes one at the time it sets),
  // so it is the fold's time.
  for (int i = 0; i < 3; ++i) {
    old_epoch_correction_[i] = FrozenCorrection{correction_[i].p, correction_[i].v, correction_[i].b};
    correction_[i] = Correction{};
  }
  old_epoch_left_ = count_;
}

// Adds the old epoch's correction, carried from the fold to each entry's time by Phi(t_e - t_fold), into
// the old epoch's entries and ends the epoch.
void PositionFilterCore::fold_old_epoch() {
  uint16_t k = static_cast<uint16_t>(head_ + capacity_ - count_);  // the oldest entry
  if (k >= capacity_) k = static_cast<uint16_t>(k - capacity_);
  uint16_t newest_old = static_cast<uint16_t>(k + old_epoch_left_ - 1);
  if (newest_old >= capacity_) newest_old = static_cast<uint16_t>(newest_old - capacity_);
  const uint32_t fold_us = history_[newest_old].t_us;
  for (uint16_t n = 0; n < old_epoch_left_; ++n) {
    HistoryEntry& e = history_[k];
    const float d = seconds_between(e.t_us, fold_us);  // (<= 0)
    for (int i = 0; i < 3; ++i) {
      const FrozenCorrection& c = old_epoch_correction_[i];
      e.p[i] += has_bias(i) ? c.p + d * (c.v - 0.5f * d * c.b) : c.p + d * c.v;
    }
    k = static_cast<uint16_t>(k + 1 == capacity_ ? 0 : k + 1);
  }
  old_epoch_left_ = 0;
}

// T, Q(T), T/2 and T^2/2 for a step of step_us (kept out of propagate(), whose usual path it is not).
void PositionFilterCore::set_step(int32_t step_us) {
  const float dt = static_cast<float>(step_us) * 1e-6f, t2 = dt * dt;
  half_dt_ = 0.5f * dt;
  h_dt_ = 0.5f * t2;  // T^2/2
  const AxisCovariance base = process_noise(dt, t2, h_dt_, qp(), qv());
  for (int c = 0; c < 2; ++c) {
    q_[c] = base;
    add_bias_noise(q_[c], dt, qb(c));
  }
  q_dt_ = dt;
  q_step_us_ = step_us;
}

// thesis eq. 8.9-8.11a per axis: x <- F x + G u with F, G of eq. 8.10 (and v' = u - b with a bias).
void PositionFilterCore::propagate(const Vec3& u, int32_t step_us) {
  // T, Q(T), T/2 and T^2/2 depend only on the step, which is the loop period on every step but the odd
  // one: cache them, keyed by the integer microseconds (so a repeated step needs no conversion either).
  if (step_us != q_step_us_) set_step(step_us);
  const float dt = q_dt_;
  // p + T v + (T^2/2) a = p + (T/2) (v + v'), v' = v + T a: the same step with one multiplication fewer
  // per axis (float rounding only; PositionFilter.PredictMatchesEquation89InDouble bounds it). The
  // accumulated correction is carried along by the same Phi(T), without input: c <- Phi(T) c.
  const float h = half_dt_;
  const float ua[3] = {u.x, u.y, u.z};
  for (int i = 0; i < 3; ++i) {
    AxisState& x = x_[i];
    Correction& c = correction_[i];
    const float v0 = x.v;
    if (has_bias(i)) {
      x.v = v0 + dt * (ua[i] - x.b);
      const float cv0 = c.v;
      c.v = cv0 - dt * c.b;
      c.p += h * (cv0 + c.v);
    } else {
      x.v = v0 + dt * ua[i];
      c.p += dt * c.v;  // (c.b is zero)
    }
    x.p += h * (v0 + x.v);
  }
  propagate_covariance(p_[0], dt, h_dt_, class_has_bias(0), q_[0]);
  if (!z_shares_xy_covariance_) propagate_covariance(p_[1], dt, h_dt_, class_has_bias(1), q_[1]);
}

void PositionFilterCore::predict(const Vec3& u, uint32_t t_us) {
  if (!clock_started_) {
    t_us_ = t_us;
    clock_started_ = true;
    return;
  }
  const int32_t step_us = micros_between(t_us, t_us_);
  if (!is_finite(u) || step_us <= 0) {  // (dt > 0 exactly when the microseconds are)
    ++health_.predict_skipped;
    return;
  }
  t_us_ = t_us;
  if (!initialized_) return;
  propagate(u, step_us);
  if (above_nonnegative(q_dt_, kMaxStep)) {  // (every prediction: float_bits.h; q_dt_ > 0)
    // A gap: earlier fixes can no longer be brought forward through a history that does not exist.
    for (int i = 0; i < 3; ++i) correction_[i] = Correction{};
    have_fix_ = false;
    drop_fix();
    clear_history();
  }
  push_history();
}

// Position on the current estimate's time line at t_us (not after now), from the history: linear
// interpolation between the entries around t_us, plus the accumulated correction carried back there,
// (1, h1, h2) . c with h1 = -tau, h2 = -tau^2/2 (Phi(-tau)'s first row; tau = now - t_us). False when
// t_us is older than the oldest entry. Ages are compared as unsigned microseconds (all within the
// history, so the clock wrap does not matter).
bool PositionFilterCore::predicted_position_at(uint32_t t_us, float out[3], float h1, float h2) {
  if (count_ == 0) return false;
  uint16_t oldest = static_cast<uint16_t>(head_ + capacity_ - count_);
  if (oldest >= capacity_) oldest = static_cast<uint16_t>(oldest - capacity_);
  auto entry = [&](uint16_t logical) -> const HistoryEntry& {
    const uint16_t k = static_cast<uint16_t>(oldest + logical);
    return history_[k >= capacity_ ? k - capacity_ : k];
  };
  const uint32_t age = t_us_ - t_us;
  if (age > t_us_ - history_[oldest].t_us) return false;
  // Binary search for the newest entry at or before t_us (ages decrease towards the newest entry).
  uint16_t lo = 0, hi = static_cast<uint16_t>(count_ - 1);
  while (lo < hi) {
    const uint16_t mid = static_cast<uint16_t>((lo + hi + 1) / 2);
    if (t_us_ - entry(mid).t_us >= age) {
      lo = mid;
    } else {
      hi = static_cast<uint16_t>(mid - 1);
    }
  }
  const HistoryEntry& a = entry(lo);
  // A capture at an entry's own time (frac = 0) takes the entry as it is (a.p + 0 (b.p - a.p) = a.p
  // exactly while the history is finite).
  const uint32_t into = t_us - a.t_us;
  const bool between = into != 0 && lo + 1 < count_;
  const HistoryEntry* b = &a;
  float frac = 0.0f;
  if (between) {
    b = &entry(static_cast<uint16_t>(lo + 1));
    const uint32_t span = b->t_us - a.t_us;  // (> into > 0)
    // The entries are a loop period apart: its reciprocal is kept, and the fraction is a multiplication
    // (rounding of the reciprocal only, < 1.2e-7 of the step's position change).
    if (span != inv_span_us_) {
      inv_span_ = 1.0f / static_cast<float>(span);
      inv_span_us_ = span;
    }
    frac = static_cast<float>(into) * inv_span_;
  }
  for (int i = 0; i < 3; ++i) {
    const Correction& c = correction_[i];
    float p = a.p[i];
    if (between) p += frac * (b->p[i] - p);
    float cp = c.p + h1 * c.v;
    if (has_bias(i)) cp += h2 * c.b;  // (elsewhere c.b is zero)
    out[i] = p + cp;
  }
  if (lo < old_epoch_left_) {
    // An entry of the old epoch: its correction too, frozen at the fold, the time of the newest old
    // entry, carried to t_us by Phi(t_us - t_fold)'s first row. Between that entry (a) and the first of
    // the current epoch (b), a's share of the interpolation only: (1 - frac) c.p (a is at the fold).
    const bool straddle = between && lo + 1 == old_epoch_left_;
    const float d = straddle ? 0.0f : seconds_between(t_us, entry(static_cast<uint16_t>(old_epoch_left_ - 1)).t_us);
    const float w = straddle ? 1.0f - frac : 1.0f;
    for (int i = 0; i < 3; ++i) {
      const FrozenCorrection& c = old_epoch_correction_[i];
      float cp = c.v;
      if (has_bias(i)) cp -= 0.5f * d * c.b;  // (elsewhere c.b is zero)
      out[i] += w * (c.p + d * cp);
    }
  }
  return true;
}

void PositionFilterCore::initialize_from_fix(const Vec3& p_ned, uint32_t capture_us) {
  if (initialized_) ++health_.resets;  // the first fix initialises; later ones here are resets
  const uint32_t now = t_us_;
  const float tau = seconds_between(now, capture_us);
  if (!(tau > 0.0f) || tau > kMaxStep) capture_us = now;
  // A jump of the fix says nothing about the acceleration bias (a property of the IMU and the tilt
  // estimate): the learned biases and their variances survive the reset, uncorrelated with the new state.
  // (Axes without a bias state hold b = 0 and bb = 0 already: set_params() clears them.)
  float bias[3], bias_var[2];
  for (int i = 0; i < 3; ++i) bias[i] = x_[i].b;
  for (int c = 0; c < 2; ++c) bias_var[c] = p_[covariance_class(c == 1 ? 2 : 0)].bb;
  // The velocity too: it comes from the IMU, not the fix, and zeroing it in flight (a fix back after
  // an outage during a failsafe descent) would let the vehicle speed up while the filter catches up. It
  // keeps the initial velocity uncertainty, so the fixes still correct it.
  // A diverged filter (the reset's other cause) keeps nothing that is not finite.
  bool keep_bias = initialized_;
  for (int i = 0; i < 3; ++i) keep_bias = keep_bias && is_finite(bias[i]);
  for (int c = 0; c < 2; ++c) keep_bias = keep_bias && is_finite(bias_var[c]) && bias_var[c] >= 0.0f;
  const Vec3 v = velocity();
  const bool keep_velocity = initialized_ && is_finite(v) && norm(v) < kMaxKeptSpeed;
  reset(p_ned, keep_velocity ? v : Vec3{}, capture_us);
  if (keep_bias) {
    for (int i = 0; i < 3; ++i) x_[i].b = bias[i];
    for (int c = 0; c < 2; ++c) p_[c].bb = bias_var[c];
    update_class_sharing();
  }
  if (capture_us != now) {
    propagate(Vec3{}, micros_between(now, capture_us));  // (the kept velocity carries the position)
    t_us_ = now;
    push_history();
  }
}

FixResult PositionFilterCore::fuse_position(const Vec3& y, uint32_t capture_us) {
  const FixResult accepted = accept_fix(y);
  if (accepted != FixResult::kPending) return accepted;
  const FixResult gated = gate_fix(y, capture_us);
  return gated == FixResult::kPending ? update_fix() : gated;
}

FixResult PositionFilterCore::accept_fix(const Vec3& y) {
  if (fix_stage_ != kFixIdle) {
    ++health_.rejected_busy;
    return FixResult::kRejectedBusy;
  }
  if (!is_finite(y) || !clock_started_) {
    ++health_.rejected_invalid;
    return FixResult::kRejectedInvalid;
  }
  offered_us_ = t_us_;
  have_offered_ = true;
  return FixResult::kPending;
}

FixResult PositionFilterCore::queue_fix(const Vec3& y, uint32_t capture_us) {
  const FixResult accepted = accept_fix(y);
  if (accepted != FixResult::kPending) return accepted;
  for (int i = 0; i < 3; ++i) fix_[i] = y[i];
  fix_us_ = capture_us;
  fix_stage_ = kFixQueued;
  return FixResult::kPending;
}

FixResult PositionFilterCore::advance_fix() {
  if (fix_stage_ == kFixQueued) {
    fix_stage_ = kFixIdle;  // (a reset in the gate must not count it as dropped)
    return gate_fix(Vec3{fix_[0], fix_[1], fix_[2]}, fix_us_);
  }
  if (fix_stage_ == kFixGated) return update_fix();
  return FixResult::kRejectedInvalid;  // nothing in progress (nothing counted)
}

// A fix resets the filter instead of correcting it: before the first fix, when the position variance
// is lost (dead reckoning through an outage; also catches NaN; z's own entry only when it has one), or
// after too many rejections in a row.
QUAD_STEP bool PositionFilterCore::fix_resets() const {
  const float lost = sqf(params_.reset_position_sigma);
  const bool diverged = !(p_[0].pp <= lost) || (!z_shares_xy_covariance_ && !(p_[1].pp <= lost));
  const bool rejected_too_often =
      params_.reset_after_rejections > 0 && consecutive_rejections_ >= params_.reset_after_rejections;
  return !initialized_ || diverged || rejected_too_often;
}

// Delayed fusion (seed 003, errata form): with D = P_now - Q(tau) and h^T = H Phi(-tau) = (1, -tau,
// -tau^2/2), the covariance at capture time is Phi(-tau) D Phi(-tau)^T, so S = h^T D h + R and the
// correction carried to now is Phi(tau) K nu = D h nu / S. Computed once per covariance class into
// w[c] = D h and fix_inv_s_[c] = 1 / S. Only w = D h is needed, so D is not formed: w = P h - Q(tau) h,
// with Q(tau) h in closed form,
//   Q(tau) h = int_0^tau Phi(t) diag(qp, qv, qb) Phi(t - tau)^T e_0 dt
//            = (qp tau - qv tau^3/6 + qb tau^5/120, -qv tau^2/2 + qb tau^4/24, -qb tau^3/6)
// (Phi(t)^T h = Phi(t - tau)^T e_0; its qp, qv part is the same for every class; float rounding only).
// h1 = -tau, h2 = -tau^2/2.
QUAD_STEP void PositionFilterCore::capture_gain_terms(float tau, float h1, float h2, float w[2][3]) {
  const float tau2 = tau * tau;
  const float tau3_6 = h2 * tau * (1.0f / 3.0f);  // -tau^3/6
  const float qv = this->qv();
  const float qh_pos = qp() * tau + qv * tau3_6, qh_vel = qv * h2;  // Q(tau) h's qp, qv part
  for (int c = 0; c < class_count(); ++c) {
    const AxisCovariance& p = p_[c];
    float w0 = p.pp + h1 * p.pv - qh_pos;
    float w1 = p.pv + h1 * p.vv - qh_vel;
    float hdh;
    if (class_has_bias(c)) {
      const float qh_bias = qb(c) * tau3_6;                  // -qb tau^3/6
      w0 += h2 * p.pb - (qh_bias * tau2) * (-1.0f / 20.0f);  // qb tau^5/120
      w1 += h2 * p.vb - 0.25f * (qh_bias * h1);              // qb tau^4/24
      const float w2 = p.pb + h1 * p.vb + h2 * p.bb - qh_bias;
      w[c][2] = w2;
      hdh = w0 + h1 * w1 + h2 * w2;  // h^T D h
    } else {
      w[c][2] = 0.0f;
      hdh = w0 + h1 * w1;  // (w_2 = 0: adding h2 w_2 = -0 would change nothing)
    }
    w[c][0] = w0;
    w[c][1] = w1;
    const float r = sqf(c == 1 ? params_.fix_sigma_z : params_.fix_sigma_xy);
    // h^T D h is the variance of the predicted position at capture time: never below zero.
    fix_inv_s_[c] = 1.0f / (maxf(hdh, 0.0f) + r);
  }
}

// Mahalanobis gate per axis: nu^2 / S <= gate^2, with nu = y - p_s the innovations (also rejects a
// non-finite innovation). Keeps each axis' normalised innovation squared for last_nis() and the test ratios.
QUAD_STEP bool PositionFilterCore::within_gate(const Vec3& y, const float p_s[3], float nu[3]) {
  const float gate2 = sqf(params_.gate_sigma);
  bool pass = true;
  for (int i = 0; i < 3; ++i) {
    nu[i] = y[i] - p_s[i];
    const float d2 = nu[i] * nu[i] * fix_inv_s_[covariance_class(i)];
    if (!(d2 <= gate2)) pass = false;
    last_d2_[i] = d2;
  }
  return pass;
}

// The first step: the lookup at capture time, D h, S and the gate. A fix that passes leaves its D h in
// gain_, 1 / S in fix_inv_s_, its innovations in fix_ and the time in fix_us_ for update_fix().
FixResult PositionFilterCore::gate_fix(const Vec3& y, uint32_t capture_us) {
  if (fix_resets()) {
    initialize_from_fix(y, capture_us);
    return FixResult::kInitialized;
  }
  // A fix stamped after "now" (clock offset) is taken as current.
  int32_t tau_us = micros_between(t_us_, capture_us);
  if (tau_us < 0) {  // (the float tau is negative exactly when the microseconds are)
    tau_us = 0;
    capture_us = t_us_;
  }
  const float tau = static_cast<float>(tau_us) * 1e-6f;  // seconds_between(t_us_, capture_us)
  // (Fixes from before a reset or a gap find no history entry: the history starts there.)
  if ((have_fix_ && micros_between(capture_us, last_fix_us_) < 0) ||
      (have_still_ && micros_between(capture_us, still_us_) < 0)) {
    ++health_.rejected_out_of_order;
    return FixResult::kRejectedOutOfOrder;
  }
  const float h1 = -tau;
  const float h2 = -0.5f * (tau * tau);  // -tau^2/2
  float p_s[3];
  if (!predicted_position_at(capture_us, p_s, h1, h2)) {
    ++health_.rejected_too_old;
    return FixResult::kRejectedTooOld;
  }
  float w[2][3];
  capture_gain_terms(tau, h1, h2, w);
  float nu[3];
  if (!within_gate(y, p_s, nu)) {
    ++health_.rejected_gate;
    ++consecutive_rejections_;
    return FixResult::kRejectedGate;
  }

  gain_tau_ = tau;
  for (int c = 0; c < class_count(); ++c) {
    for (int j = 0; j < 3; ++j) gain_[c][j] = w[c][j];
  }
  for (int i = 0; i < 3; ++i) fix_[i] = nu[i];
  fix_us_ = t_us_;
  last_fix_us_ = capture_us;
  have_fix_ = true;
  fix_stage_ = kFixGated;
  return FixResult::kPending;
}

// The second step: the gated fix's correction, carried by Phi(T) from the time it was gated to now,
// into the covariance and the state.
FixResult PositionFilterCore::update_fix() {
  fix_stage_ = kFixIdle;
  const int classes = class_count();
  const float* const inv_s = fix_inv_s_;
  const float* const nu = fix_;
  const int32_t carry_us = micros_between(t_us_, fix_us_);
  if (carry_us != 0) {
    // predict() ran since the gate: D h becomes Phi(T) D h (rows of Phi(T) = [[1, T, -T^2/2], [0, 1, -T],
    // [0, 0, 1]]), so that P -= (Phi D h)(Phi D h)^T / S and x += Phi D h nu / S are the update made at
    // the gate and predicted since.
    const float t = static_cast<float>(carry_us) * 1e-6f, h = 0.5f * (t * t);
    for (int c = 0; c < classes; ++c) {
      float* w = gain_[c];
      w[0] += t * w[1] - h * w[2];  // (w_2 = 0 without a bias state)
      w[1] -= t * w[2];
    }
    gain_tau_ += t;
  }
  for (int c = 0; c < classes; ++c) {
    float* k = gain_[c];  // D h, turned into the gain in place
    const float w[3] = {k[0], k[1], k[2]};
    const bool bias = class_has_bias(c);
    k[2] = 0.0f;  // w_2 = 0 without a bias state
    for (int j = 0; j < (bias ? 3 : 2); ++j) k[j] = w[j] * inv_s[c];
    // thesis eq. 8.11b (errata) at capture time, carried to now: P_now -= (D h)(D h)^T / S.
    AxisCovariance& p = p_[c];
    p.pp -= k[0] * w[0];
    p.pv -= k[0] * w[1];
    p.vv -= k[1] * w[1];
    if (bias) {
      p.pb -= k[0] * w[2];
      p.vb -= k[1] * w[2];
      p.bb -= k[2] * w[2];
    }
  }
  bool fold = false;
  for (int i = 0; i < 3; ++i) {
    if (correct_axis(i, gain_[covariance_class(i)], nu[i])) fold = true;
  }
  if (fold) fold_correction();
  consecutive_rejections_ = 0;
  ++health_.fused;
  return FixResult::kFused;
}

bool PositionFilterCore::correct_axis(int i, const float k[3], float nu) {
  AxisState& x = x_[i];
  Correction& c = correction_[i];
  const float dp = k[0] * nu, dv = k[1] * nu;
  x.p += dp;
  x.v += dv;
  c.p += dp;
  c.v += dv;
  if (has_bias(i)) {  // elsewhere k[2] is zero
    const float db = k[2] * nu;
    x.b += db;
    c.b += db;
  }
  // |c.p| <= 1/2 and |c.v| <= 2 keep the sum at or below 1 (0.25 |c.v| is exact, rounding is
  // monotonic and 1 is a float): two comparisons decide the usual case exactly (on the bit patterns,
  // float_bits.h: every fix's three axes).
  return !(abs_at_most(c.p, 0.5f * kFoldThreshold) && abs_at_most(c.v, 2.0f * kFoldThreshold)) &&
         absf(c.p) + 0.25f * absf(c.v) > kFoldThreshold;
}

// thesis eq. 8.11b (errata) for H = e_m, at the current time and on every axis: w = P H^T (P's column m),
// S = w_m + r, K = w / S, x += K (y - x_m), P -= w w^T / S. The same H and r on every axis keep the
// covariance classes as they were: shared stays shared.
void PositionFilterCore::update_now(int m, const Vec3& y, float r) {
  float k[2][3];
  for (int c = 0; c < class_count(); ++c) {
    AxisCovariance& p = p_[c];
    const float w0 = m == 0 ? p.pp : p.pv, w1 = m == 0 ? p.pv : p.vv, w2 = m == 0 ? p.pb : p.vb;
    const float inv_s = 1.0f / (maxf(m == 0 ? w0 : w1, 0.0f) + r);
    k[c][0] = w0 * inv_s;
    k[c][1] = w1 * inv_s;
    k[c][2] = w2 * inv_s;  // (0 without a bias state: pb = vb = 0)
    p.pp -= k[c][0] * w0;
    p.pv -= k[c][0] * w1;
    p.vv -= k[c][1] * w1;
    if (class_has_bias(c)) {
      p.pb -= k[c][0] * w2;
      p.vb -= k[c][1] * w2;
      p.bb -= k[c][2] * w2;
    }
  }
  bool fold = false;
  for (int i = 0; i < 3; ++i) {
    const float nu = y[i] - (m == 0 ? x_[i].p : x_[i].v);
    if (correct_axis(i, k[covariance_class(i)], nu)) fold = true;
  }
  if (fold) fold_correction();
}

// The delayed fusion takes the covariance at a fix's capture time s from the current one, P_now - Q(tau),
// which holds only while nothing was fused after s: while fixes arrive (one offered within the history
// window) they hold the estimate and the still measurements wait, and a fix captured before the last
// still measurement is refused as out of order (gate_fix()); the first fix after a hold may be that one,
// the next ones are fused.
bool PositionFilterCore::fuse_still(const Vec3& p_hold, float sigma_p, float sigma_v) {
  if (!initialized_ || fix_stage_ != kFixIdle || have_offered_ || !is_finite(p_hold)) return false;
  update_now(1, Vec3{}, sqf(sigma_v));
  update_now(0, p_hold, sqf(sigma_p));
  still_us_ = t_us_;
  have_still_ = true;
  return true;
}

bool PositionFilterCore::fuse_zero_velocity(float sigma_v) {
  if (!initialized_ || fix_stage_ != kFixIdle || have_offered_) return false;
  // A reset of the velocity, not an update: its error at a touchdown comes from the jolt (the
  // accelerometer's samples of it, averaged over a prediction step), not from the dead reckoning before,
  // so the position (correlated with the velocity by that dead reckoning) is not to be corrected by it.
  const float stop[3] = {0.0f, 1.0f, 0.0f};
  bool fold = false;
  for (int i = 0; i < 3; ++i) {
    if (correct_axis(i, stop, -x_[i].v)) fold = true;
  }
  if (fold) fold_correction();
  for (int c = 0; c < class_count(); ++c) {
    AxisCovariance& p = p_[c];
    p.pv = 0.0f;
    p.vv = sqf(sigma_v);
    p.vb = 0.0f;
  }
  still_us_ = t_us_;
  have_still_ = true;
  return true;
}

bool PositionFilterCore::constrain_above_floor(float z_floor) {
  AxisState& z = x_[2];
  if (!initialized_ || fix_stage_ != kFixIdle || have_offered_ || !(z.p > z_floor)) return false;
  // The position alone, with unit gain: the velocity stays, for the touchdown's deceleration, which the
  // accelerometer measures, takes it to zero (zeroed here, it would come back as a climb).
  const float to_floor[3] = {1.0f, 0.0f, 0.0f};
  if (correct_axis(2, to_floor, z_floor - z.p)) fold_correction();
  return true;
}

void PositionFilterCore::initialize_at(const Vec3& p) {
  const uint32_t now = t_us_;
  reset(p, Vec3{}, now);
}

}  // namespace est
}  // namespace quad

namespace quad {
namespace est {

float PositionFilterCore::test_ratio_horizontal() const {
  return maxf(last_d2_[0], last_d2_[1]) / sqf(params_.gate_sigma);
}

float PositionFilterCore::test_ratio_vertical() const { return last_d2_[2] / sqf(params_.gate_sigma); }

}  // namespace est
}  // namespace quad
