#include "quad/estimation/conditioned_observer.h"

#include "quad/estimation/vector_attitude.h"
#include "quad/math/float_bits.h"

namespace quad {
namespace est {

namespace {

constexpr float kMaxDt = 0.5f;  // s: a longer gap is not one sample period

// Thesis sec. 4.3: eq. 4.15 with cos(x) ~ 1 - x^2/2 and sinc(x) ~ 1 - x^2/6, x = T |Omega| / 2. The
// approximation changes the squared norm by only ~x^4/12 per step, so one Newton step of 1/sqrt, (3 - |q|^2)/2,
// renormalises to round-off without the square root and division of a full normalisation.
// half_dt_sq = (dt/2)^2 comes from the caller's per-dt cache.
// Without `renormalise` the Newton step is left out: the norm then moves by x^4/24 per step (1.6e-7 at
// 35 rad/s and 400 Hz) plus round-off, which the next renormalised step takes back.
Quat propagate_second_order(const Quat& q, const Vec3& omega, float dt, float half_dt_sq, bool renormalise = true) {
  const float half_dt = 0.5f * dt;
  const float x2 = half_dt_sq * dot(omega, omega);
  const float k = half_dt * (1.0f - x2 * (1.0f / 6.0f));
  const Quat d{1.0f - 0.5f * x2, omega.x * k, omega.y * k, omega.z * k};
  // A(Omega) q = q (x) d (eq. 3.11), written out as operator* computes it (the same roundings) to
  // spare the AVR the call and the copies of both operands: this runs in every iteration.
  const Quat n{q.w * d.w - q.x * d.x - q.y * d.y - q.z * d.z, q.w * d.x + q.x * d.w + q.y * d.z - q.z * d.y,
               q.w * d.y - q.x * d.z + q.y * d.w + q.z * d.x, q.w * d.z + q.x * d.y - q.y * d.x + q.z * d.w};
  return renormalise ? n * (1.5f - 0.5f * dot(n, n)) : n;
}

// The multi-rate form renormalises on the third propagation after a correction (at 400 Hz the
// propagation just before the next correction, the lightest iteration of the frame), and in any case
// on every fourth step in a row (a caller that only corrects, or only propagates). update()
// renormalises every step.
constexpr uint8_t kRenormalisingPropagation = 3;
constexpr uint8_t kMaxUnnormalisedSteps = 3;

}  // namespace


ConditionedObserver::ConditionedObserver(const ObserverParams& params) : params_(params) { cache_reference(); }

void ConditionedObserver::set_params(const ObserverParams& params) {
  // A reference learned at initialisation survives a change of gains in flight (else the heading jumps).
  const bool keep_learned = initialized_ && params_.mag_ref_from_init && params.mag_ref_from_init;
  const Vec3 learned = params_.mag_ref_ned;
  params_ = params;
  if (keep_learned) params_.mag_ref_ned = learned;
  cache_reference();
}

// The inertial reference direction, the constant denominator and the accelerometer gate, computed
// once per parameter set rather than on every sample.
void ConditionedObserver::cache_reference() {
  const float lo = maxf(1.0f - params_.accel_norm_tolerance, 0.0f) * kGravity;
  const float hi = (1.0f + params_.accel_norm_tolerance) * kGravity;
  accel_lo2_ = lo * lo;
  accel_hi2_ = hi * hi;
  const Vec3& m = params_.mag_ref_ned;
  if (params_.innovation == Innovation::kConditioned) {
    // thesis eq. 4.7: v_I = pi_{e3} m_I / ||pi_{e3} m_I||; pi_{e3} m = (m_N, m_E, 0).
    const Vec3 h{m.x, m.y, 0.0f};
    const float n = norm(h);
    inv_mag_h_ = n > 0.0f ? 1.0f / n : 0.0f;  // eq. 4.8 denominator (errata: the inertial norm)
    v_ref_ = h * inv_mag_h_;
    // A reference along magnetic north (the learned one: m_E = 0) is exactly e1, not m_N (1/m_N) (which
    // can round to one ulp below 1): update()'s v_hat is then row 0 of R exactly.
    if (m.y == 0.0f && n > 0.0f) v_ref_.x = m.x > 0.0f ? 1.0f : -1.0f;
  } else {
    // thesis eq. 4.3a: v_I = m_I / ||m_I||
    const float n = norm(m);
    inv_mag_h_ = n > 0.0f ? 1.0f / n : 0.0f;
    v_ref_ = m * inv_mag_h_;
  }
  k2_mag_ = params_.k2 * inv_mag_h_;
  // just below Delta / sqrt(3) (1/sqrt(3) = 0.5773503); zero for a Delta that is not positive
  inner_delta_ = params_.delta > 0.0f ? params_.delta * 0.57735f : 0.0f;
  step_dt_ = -1.0f;  // the step gains below belong to the old parameters
}

// Terms that depend only on the parameters and the step dt (the loop period on every step but the odd
// one): computed when dt changes rather than on every sample.
void ConditionedObserver::cache_step(float dt) {
  step_dt_ = dt;
  k3_dt_ = params_.k3 * dt;
  k4_mag_dt_ = params_.k4 * inv_mag_h_ * dt;
  k_i_dt_ = params_.k_i * dt;
  kb_dt_ = params_.kb * dt;
}

void ConditionedObserver::cache_propagation(float dt) {
  prop_dt_ = dt;
  half_dt_sq_ = 0.25f * dt * dt;
}

// 0 < dt <= kMaxDt and a finite gyro; counts the skipped sample otherwise. The observer's per-step tests
// (the dt checks, the caches keyed on dt's bits, the accelerometer gate, the magnetometer's, the bias
// cube) are on the bit patterns (float_bits.h: 700 cycles off the median 200 Hz PIL iteration).
bool ConditionedObserver::step_ok(const Vec3& gyro, float dt) {
  if (!is_finite(gyro) || !positive_at_most(dt, kMaxDt)) {
    ++health_.skipped;
    return false;
  }
  if (!same_bits(dt, prop_dt_)) cache_propagation(dt);
  return true;
}

// The step's result, unless it is not finite (then the state stays as it was, and the step is counted).
bool ConditionedObserver::commit(const Quat& q_next, const Vec3& b_next, const Vec3& rate) {
  if (!is_finite(q_next) || !is_finite(b_next)) {
    ++health_.state_restored;
    return false;
  }
  q_ = q_next;
  bias_ = b_next;
  rate_ = rate;
  return true;
}

bool ConditionedObserver::initialize(const Vec3& accel_frd, const Vec3& mag_frd) {
  if (params_.mag_ref_from_init) {
    Vec3 ref;
    if (!magnetic_reference_from_sample(accel_frd, mag_frd, ref)) return false;
    params_.mag_ref_ned = ref;
    cache_reference();
  }
  Quat q;
  if (!attitude_from_vectors(accel_frd, mag_frd, params_.mag_ref_ned, q)) return false;
  reset(q, Vec3{});
  return true;
}

void ConditionedObserver::reset(const Quat& q_ib, const Vec3& gyro_bias) {
  q_ = normalized(q_ib);
  r_ = to_dcm(q_);
  r_stale_ = false;
  unnormalised_steps_ = 0;
  propagations_since_correction_ = 0;
  sigma_r_ = Vec3{};
  // eq. 4.9 requires ||b(0)|| < Delta.
  bias_ = is_finite(gyro_bias) ? sat_delta(gyro_bias, 0.999f * params_.delta) : Vec3{};
  rate_ = Vec3{};
  initialized_ = true;
}

void ConditionedObserver::propagate(const Vec3& gyro, float dt) {
  if (!step_ok(gyro, dt)) return;
  const Vec3 rate = gyro - bias_;
  const Vec3 omega = rate + sigma_r_;  // eq. 4.10 with the held innovation
  if (propagations_since_correction_ < 255u) ++propagations_since_correction_;
  const bool renormalise = propagations_since_correction_ == kRenormalisingPropagation ||
                           unnormalised_steps_ >= kMaxUnnormalisedSteps;
  const Quat q_next = params_.propagator == Propagator::kExact
                          ? normalized(integrate_exact(q_, omega, dt))
                          : propagate_second_order(q_, omega, dt, half_dt_sq_, renormalise);
  if (!commit(q_next, bias_, rate)) return;
  unnormalised_steps_ = renormalise ? 0u : static_cast<uint8_t>(unnormalised_steps_ + 1u);
  r_stale_ = true;
  ++health_.propagations;
}

// The star's attitude as a third innovation beside eq. 4.9's two: Mahony's direct complementary filter
// takes omega = vex(P_a(R~)), R~ = R_hat^T R_y, from a measured rotation R_y, which for q~ = q_hat* (x) q_y
// is 2 q~_0 q~_v (the Mahony baseline's form): sin of the error angle about its axis, no trigonometry.
// Per axis times the gain, it is applied at once rather than held over the fix period (the integral of
// the term over one period, the same to first order, and no state for the AVR), in NED: R_then d, the
// error at the capture time, is the error propagation leaves unchanged.
bool ConditionedObserver::correct_attitude(const Quat& q_meas, const Quat& q_then, const Vec3& gain) {
  if (!is_finite(q_meas)) return false;
  const Quat q_err = conjugate(q_then) * q_meas;
  // vex(P_a(R~)) in the body frame at the capture time (q~ and -q~ give the same: the short way).
  const float two_w = 2.0f * q_err.w;
  const Vec3 xi{two_w * q_err.x, two_w * q_err.y, two_w * q_err.z};
  if (!(xi.x * xi.x + xi.y * xi.y <= kMaxAttitudeFixTilt * kMaxAttitudeFixTilt)) return false;
  const Vec3 d = rotate(q_then, Vec3{gain.x * xi.x, gain.y * xi.y, gain.z * xi.z});  // in NED
  // exp(d / 2) (x) q to second order, then one Newton step of 1/sqrt on the norm (as the propagator).
  const Quat n = Quat{1.0f, 0.5f * d.x, 0.5f * d.y, 0.5f * d.z} * q_;
  if (!commit(n * (1.5f - 0.5f * dot(n, n)), bias_, rate_)) return false;
  r_stale_ = true;
  return true;
}

Vec3 attitude_fix_gain(const float* att_cov, AttitudeFixWeights w) {
  const float floor_var = w.floor_sigma * w.floor_sigma;
  const float default_var = w.fix_sigma * w.fix_sigma;
  const float p_tilt = w.tilt_sigma * w.tilt_sigma;
  const float p_heading = w.heading_sigma * w.heading_sigma;
  const float c[3] = {att_cov != nullptr ? att_cov[0] + floor_var : default_var,
                      att_cov != nullptr ? att_cov[3] + floor_var : default_var,
                      att_cov != nullptr ? att_cov[5] + floor_var : default_var};
  const float p[3] = {p_tilt, p_tilt, p_heading};
  float g[3];
  for (int i = 0; i < 3; ++i) {
    const float s = p[i] + c[i];
    // (a non-finite or negative covariance gives no correction rather than a wild one)
    g[i] = s > 0.0f && c[i] >= 0.0f ? minf(p[i] / s, w.max_gain) : 0.0f;
  }
  return Vec3{g[0], g[1], g[2]};
}

// Gravity direction from the accelerometer (eq. 4.3b / 4.8: u_B = -a_B / g, here normalised so that
// pi_{u_B} is an exact projector). Only used while the specific force is close to g in norm; false
// (and counted) otherwise.
QUAD_STEP bool ConditionedObserver::gravity_direction(const Vec3& accel, Vec3& u_meas) {
  const float a2 = dot(accel, accel);  // (norm_sq, without its extra call level)
  if (!in_open_range(a2, accel_lo2_, accel_hi2_)) {
    ++health_.accel_rejected;
    return false;
  }
  u_meas = accel * (-1.0f / sqrtf(a2));
  return true;
}

// The magnetometer's terms of the innovations, eq. 4.9 (or 4.4), added to sigma_r and db. `axis` is the
// measured vertical u_B, or the estimated one without a usable accelerometer.
QUAD_STEP void ConditionedObserver::add_heading_innovation(const Vec3& mag, const Vec3& u_hat, const Vec3& axis,
                                                           Vec3& sigma_r, Vec3& db) const {
  // v_hat_B = R^T v_I = sum_i v_I,i (row i of R): only the rows the reference needs (the learned
  // reference and any conditioned one have no vertical part; a zero declination needs row 0 only, and
  // the learned reference's 1 no multiplication). The zero and one tests, with k1 = 1 below, are on the
  // bit patterns (float_bits.h: 950 cycles off the longest iteration of the 200 Hz PIL flight).
  Vec3 v_hat;
  if (!is_zero(v_ref_.x)) v_hat = is_one(v_ref_.x) ? r_.row(0) : r_.row(0) * v_ref_.x;
  if (!is_zero(v_ref_.y)) v_hat += r_.row(1) * v_ref_.y;
  if (!is_zero(v_ref_.z)) v_hat += u_hat * v_ref_.z;
  if (params_.innovation == Innovation::kConditioned) {
    // eq. 4.8: v_B = pi_{u_B} m_B / ||pi_{u_I} m_I||. Without a usable accelerometer the estimated
    // vertical stands in for u_B so the heading is still held.
    // The constant 1/||pi_{u_I} m_I|| is folded into the gains (k2_mag_, k4_mag_dt_) instead of the vector.
    const Vec3 e_v = cross(mag - axis * dot(axis, mag), v_hat);  // sk(v_B) v_hat / inv_mag_h_
    // eq. 4.9: k2 u_hat u_hat^T sk(v_B) v_hat: the heading correction acts about the estimated vertical.
    sigma_r += u_hat * (k2_mag_ * dot(u_hat, e_v));
    db -= e_v * k4_mag_dt_;
  } else {
    // eq. 4.3b: v_B = m_B / ||m_B||, and eq. 4.4: sigma_R = ... + k2 sk(v_B) v_hat.
    const float mag_sq = norm_sq(mag);
    if (mag_sq > 0.0f) sigma_r += cross(mag, v_hat) * (params_.k2 / sqrtf(mag_sq));
  }
}

// eq. 4.17: b_{k+1} = b_k + T (-k_b b_k + k_b sat_Delta(b_k) + sigma_b,k); the first two terms cancel
// inside the Delta ball, and outside it pull the estimate back (the unconditioned eq. 4.4 has none):
// sat_Delta(b) - b = b (Delta/|b| - 1), added to db.
// Inside the cube |b_i| <= Delta/sqrt(3) the norm cannot exceed Delta: three comparisons decide the
// usual case without the squared norm.
QUAD_STEP void ConditionedObserver::add_bias_pullback(Vec3& db) const {
  const ObserverParams& k = params_;
  if (k.innovation != Innovation::kConditioned ||
      (abs_at_most(bias_.x, inner_delta_) && abs_at_most(bias_.y, inner_delta_) &&
       abs_at_most(bias_.z, inner_delta_))) {
    return;
  }
  const float b2 = norm_sq(bias_);
  if (b2 > k.delta * k.delta) db += bias_ * (kb_dt_ * (k.delta / sqrtf(b2) - 1.0f));
}

void ConditionedObserver::step(const Vec3& gyro, const Vec3& accel, const Vec3& mag, bool mag_valid, float dt,
                               float correction_dt, bool multi_rate) {
  if (!step_ok(gyro, dt)) return;
  // A correction step the dt check would refuse (a multi-rate caller's bookkeeping gone wrong) corrects
  // over the attitude step instead.
  if (!positive_at_most(correction_dt, kMaxDt)) correction_dt = dt;
  if (r_stale_) {
    r_ = to_dcm(q_);
    r_stale_ = false;
  }
  const ObserverParams& k = params_;
  // Estimated directions in the body frame: with q = q_IB, u_hat_B = R^T u_I (the transpose of what
  // eq. 4.5 prints; the convergence tests pin the sign). R^T e3 is the third row of R (eq. 3.18), kept
  // from the end of the last step.
  const Vec3 u_hat = r_.row(2);
  Vec3 u_meas;
  const bool use_accel = gravity_direction(accel, u_meas);
  bool use_mag = false;
  if (mag_valid) {
    use_mag = is_finite(mag) && positive(inv_mag_h_);
    if (!use_mag) ++health_.mag_rejected;
  }
  if (!same_bits(correction_dt, step_dt_)) cache_step(correction_dt);

  // Innovations of the attitude and the bias, eq. 4.9 (or 4.4); assigned by their first term. The bias
  // innovation is kept as its step T sigma_b (eq. 4.17), T folded into the cached gains.
  Vec3 sigma_r, db;
  if (use_accel) {
    const Vec3 e_u = cross(u_meas, u_hat);
    sigma_r = is_one(k.k1) ? e_u : e_u * k.k1;  // (table 8.1: k1 = 1)
    db = e_u * -k3_dt_;
  }
  if (use_mag) add_heading_innovation(mag, u_hat, use_accel ? u_meas : u_hat, sigma_r, db);
  if (k.innovation == Innovation::kUnconditioned) db = sigma_r * -k_i_dt_;  // eq. 4.4: b' = -k_I sigma_R

  // eq. 4.10: Omega_hat = Omega_m - b + sigma_R, then eq. 4.18 (4.15 exact, or its second-order form).
  const Vec3 rate = gyro - bias_;
  const Vec3 omega = rate + sigma_r;
  // Single-rate, every step renormalises; multi-rate, the fourth unnormalised step in a row does (the
  // propagation before the next correction, at 400 Hz: the correction's iteration is the heaviest).
  const bool renormalise = !multi_rate || unnormalised_steps_ >= kMaxUnnormalisedSteps;
  const Quat q_next = k.propagator == Propagator::kExact
                          ? normalized(integrate_exact(q_, omega, dt))
                          : propagate_second_order(q_, omega, dt, half_dt_sq_, renormalise);
  add_bias_pullback(db);
  const Vec3 b_next = bias_ + db;

  if (!commit(q_next, b_next, rate)) return;
  unnormalised_steps_ = renormalise ? 0u : static_cast<uint8_t>(unnormalised_steps_ + 1u);
  propagations_since_correction_ = 0;  // the frame starts here, whatever the phase it was started at
  sigma_r_ = sigma_r;
  if (multi_rate) {
    // dcm() stays the rotation this correction used (the attitude at its start): the prediction of the
    // next iteration rotates the mean specific force of the four iterations around it with it.
    r_stale_ = true;
  } else {
    r_ = to_dcm(q_);
  }
  ++health_.updates;
}

}  // namespace est
}  // namespace quad
