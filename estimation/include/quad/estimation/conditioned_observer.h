// Conditioned nonlinear attitude observer (thesis ch. 4: eq. 4.7-4.10, discrete form eq. 4.18).
//
// Usage:
//   quad::est::ObserverParams p;               // thesis table 8.1 gains by default
//   p.mag_ref_ned = {...};                      // or keep p.mag_ref_from_init = true
//   quad::est::ConditionedObserver obs(p);
//   obs.initialize(accel_frd, mag_frd);         // from the first samples: right at any boot attitude
//   every IMU sample:
//     obs.update(gyro_frd, accel_frd, mag_frd, mag_is_new_and_valid, dt);
//     quad::Quat q = obs.attitude();            // q_IB (body FRD -> NED)
//     quad::Vec3 w = obs.rate();                // gyro minus estimated bias, for the rate controller
//     const quad::Mat3& r = obs.dcm();          // R(q) of eq. 3.18, e.g. for kinematic_acceleration()
//   or, with the correction at a lower rate than the gyro (a 400 Hz attitude loop on a 100 Hz
//   estimator, as the ATmega2560 needs): correct(..., dt, correction_dt) on the correction samples and
//   propagate(gyro_frd, dt) on the others.
//
// Units: gyro rad/s, accelerometer m/s^2 (specific force, reads (0,0,-g) level at rest), magnetometer any
// unit as long as mag_ref_ned uses the same one (mag_ref_from_init learns it from the first sample).
// Bad samples never touch the state: a non-finite gyro or dt skips the step, an accelerometer whose norm
// is far from g (or non-finite) drops the gravity correction, a non-finite or degenerate magnetometer
// sample drops the heading correction; each case is counted in health().
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace est {

// How the attitude is carried over one sample period.
enum class Propagator : uint8_t {
  kExact,        // cos/sinc of eq. 4.14 (two transcendental calls)
  kSecondOrder,  // thesis sec. 4.3: second-order Taylor terms, no trigonometry (the APM 2.5 form)
};

// Which innovation drives the observer.
enum class Innovation : uint8_t {
  kConditioned,    // eq. 4.7-4.9: the magnetometer only turns the estimate about the estimated vertical
  kUnconditioned,  // eq. 4.3-4.4 (Mahony's explicit filter): the magnetometer also tilts the estimate
};

struct ObserverParams {
  // Thesis table 8.1.
  float k1 = 1.0f;        // gravity direction gain
  float k2 = 0.2f;        // heading gain
  float k3 = 0.03125f;    // bias gain, gravity term
  float k4 = 0.00625f;    // bias gain, heading term
  float kb = 16.0f;       // pull-back rate of the bias estimate outside the ball of radius delta
  float delta = 0.03f;    // bound on the gyro bias norm, rad/s
  // Unconditioned mode only: the integral gain k_I of eq. 4.4 (b' = -k_I sigma_R).
  float k_i = 0.03125f;
  Innovation innovation = Innovation::kConditioned;
  Propagator propagator = Propagator::kSecondOrder;
  // Earth field in NED, in the magnetometer's units. Ignored when mag_ref_from_init is set: initialize()
  // then takes it from the first sample with magnetic north as the x axis (seed 001's "SAC" convention).
  Vec3 mag_ref_ned{0.42f, 0.0f, 0.91f};
  bool mag_ref_from_init = true;
  // The gravity correction is used only while | |a|/g - 1 | stays below this (specific force of
  // manoeuvres is not gravity).
  float accel_norm_tolerance = 0.2f;
};

struct ObserverHealth {
  uint32_t updates = 0;          // samples that corrected and propagated the state (update())
  uint32_t propagations = 0;     // samples that only propagated it (propagate())
  uint32_t skipped = 0;          // samples dropped entirely (non-finite gyro, dt not in (0, 0.5] s)
  uint32_t accel_rejected = 0;   // samples whose accelerometer was not used
  uint32_t mag_rejected = 0;     // samples flagged valid whose magnetometer was not used
  uint32_t state_restored = 0;   // steps whose result was non-finite and was discarded
};

// A measured attitude whose tilt is further than this from the estimate's is refused (rad, 5.7 deg: the
// observer's tilt error in flight is a tenth of a degree; a heading error is taken up to the star's
// quarter-turn ambiguity, 45 deg).
constexpr float kMaxAttitudeFixTilt = 0.1f;

// What weighs a measured attitude against the observer's estimate (attitude_fix_gain()).
struct AttitudeFixWeights {
  float tilt_sigma;     // rad: the observer's tilt error assumed at a fix (about body x, y)
  float heading_sigma;  // rad: its heading error (about body z)
  float fix_sigma;      // rad, per axis: a fix without a covariance
  float floor_sigma;    // rad, per axis: added to a fix's covariance (it describes one fix's scatter only)
  float max_gain;       // per fix: the correction acts on a delayed error, so it stays well below one
};

// Per-axis gains for correct_attitude(): alpha_i = P_i / (P_i + C_ii + floor^2), at most max_gain, with P
// the observer's assumed error variance (tilt on x, y; heading on z) and C the fix's attitude covariance
// (rad^2, body axes, upper triangle xx xy xz yy yz zz), or fix_sigma^2 without one (att_cov null).
// (w by value: on the AVR a constant passed by reference is kept in RAM.)
Vec3 attitude_fix_gain(const float* att_cov, AttitudeFixWeights w);

class ConditionedObserver {
 public:
  ConditionedObserver() : ConditionedObserver(ObserverParams{}) {}
  explicit ConditionedObserver(const ObserverParams& params);

  // Replaces the parameters (gains, reference field, modes) without touching the state. A reference
  // learned by initialize() is kept while mag_ref_from_init stays set.
  void set_params(const ObserverParams& params);
  const ObserverParams& params() const { return params_; }

  // Attitude from one accelerometer/magnetometer pair (TRIAD); bias set to zero. Returns false (state
  // unchanged) for unusable samples. update() before a successful initialize() starts from the identity.
  bool initialize(const Vec3& accel_frd, const Vec3& mag_frd);
  // Explicit state, e.g. from a stationary calibration; the bias is clamped into the delta ball.
  void reset(const Quat& q_ib, const Vec3& gyro_bias);

  // One sample: thesis eq. 4.18 with the innovation of eq. 4.9 (or 4.4).
  void update(const Vec3& gyro_frd, const Vec3& accel_frd, const Vec3& mag_frd, bool mag_valid, float dt) {
    step(gyro_frd, accel_frd, mag_frd, mag_valid, dt, dt, false);
  }
  // Multi-rate form, for a correction that runs at a lower rate than the propagation: the same step,
  // with `correction_dt` (the time since the previous correction) the step of the bias (eq. 4.17) and
  // `dt` the step of the attitude. The attitude innovation is held (zero-order) until the next
  // correction, and propagate() applies it on the samples in between, so per unit of time the
  // correction is the single-rate one. Unlike update(), it leaves dcm() at the rotation it used (the
  // attitude at its start) and does not renormalise (unless three steps in a row already did not): the
  // correction's iteration is the heaviest of a 400 Hz loop.
  void correct(const Vec3& gyro_frd, const Vec3& accel_frd, const Vec3& mag_frd, bool mag_valid, float dt,
               float correction_dt) {
    step(gyro_frd, accel_frd, mag_frd, mag_valid, dt, correction_dt, true);
  }
  // A sample between two corrections: eq. 4.18 with Omega_m - b + sigma_R, sigma_R held from the last
  // correction, the bias unchanged. The same checks as update() (a bad gyro or dt skips the sample). It
  // renormalises the attitude on the third propagation after a correction (and on every fourth step in
  // a row without one): |q| stays within ~1e-6 of one.
  void propagate(const Vec3& gyro_frd, float dt);

  // A measured attitude, the star's from a vision fix (the extension of eq. 4.9 in docs/estimation.md,
  // "The star's attitude in the thesis pair"): q_meas measures q_IB at a past time, when the estimate
  // was q_then (the attitude history at the fix's capture time). The estimate turns by gain.x, .y, .z
  // times the body-frame error vex(P_a(R_then^T R_meas)) (sin of the error angle about its axis) about
  // the body x, y, z axes, applied in NED (the error there is what propagation keeps) to the present.
  // The bias is left alone. False, and nothing changed, for a tilt error above kMaxAttitudeFixTilt (not
  // a fix of this attitude) or a result that is not finite (counted in health()).
  bool correct_attitude(const Quat& q_meas, const Quat& q_then, const Vec3& gain);

  const Quat& attitude() const { return q_; }           // q_IB
  // R_IB = R(attitude()) of eq. 3.18, computed once per update() and shared: the observer reads the
  // estimated directions off it on the next step, and callers can rotate with it (one matrix-vector
  // product instead of a quaternion rotation). In the multi-rate form it is the rotation of the last
  // correct() (the attitude at its start), and propagate() does not change it.
  const Mat3& dcm() const { return r_; }
  const Vec3& gyro_bias() const { return bias_; }       // b of eq. 4.2, rad/s
  const Vec3& rate() const { return rate_; }            // Omega_m - b, rad/s (last sample)
  bool initialized() const { return initialized_; }
  const ObserverHealth& health() const { return health_; }

 private:
  void cache_reference();
  void step(const Vec3& gyro, const Vec3& accel, const Vec3& mag, bool mag_valid, float dt, float correction_dt,
            bool multi_rate);
  void cache_step(float dt);
  void cache_propagation(float dt);
  bool step_ok(const Vec3& gyro, float dt);
  bool commit(const Quat& q_next, const Vec3& b_next, const Vec3& rate);
  bool gravity_direction(const Vec3& accel, Vec3& u_meas);
  void add_heading_innovation(const Vec3& mag, const Vec3& u_hat, const Vec3& axis, Vec3& sigma_r, Vec3& db) const;
  void add_bias_pullback(Vec3& db) const;

  ObserverParams params_;
  Vec3 v_ref_;            // v_I: eq. 4.7 (conditioned) or 4.3a (unconditioned)
  // These caches are set by cache_reference(), which every constructor calls, so they carry no
  // initialisers of their own (each one is AVR flash in the constructor).
  float inv_mag_h_;     // 1 / ||pi_{u_I} m_I|| (eq. 4.8 denominator) or 1 / ||m_I|| (eq. 4.3b)
  float k2_mag_;        // k2 / ||pi_{u_I} m_I|| (eq. 4.8/4.9)
  float inner_delta_;   // Delta / sqrt(3): a bias inside this cube is inside the Delta ball
  float accel_lo2_, accel_hi2_;  // accelerometer gate on |a|^2
  float step_dt_;                // correction step of the gains below; cache_reference() sets -1 (matches no dt)
  float prop_dt_ = -1.0f;        // attitude step of half_dt_sq_
  // Cached for those steps: (dt/2)^2, and the bias gains times the correction step (eq. 4.17 takes
  // T sigma_b); set before the first step uses them, zero until then (a copy never reads an
  // indeterminate value).
  float half_dt_sq_ = 0.0f;
  float k3_dt_ = 0.0f, k4_mag_dt_ = 0.0f, k_i_dt_ = 0.0f, kb_dt_ = 0.0f;
  Quat q_;
  Mat3 r_ = Mat3::identity();  // R(q_) as of the last update() or reset()
  bool r_stale_ = false;       // propagate() has moved q_ since r_ was computed
  uint8_t unnormalised_steps_ = 0;  // steps since the last Newton renormalisation
  uint8_t propagations_since_correction_ = 0;
  Vec3 sigma_r_;               // the attitude innovation of the last update(), held for propagate()
  Vec3 bias_;
  Vec3 rate_;
  bool initialized_ = false;
  ObserverHealth health_;
};

}  // namespace est
}  // namespace quad
