// Per-axis Kalman filter for NED position and velocity with delayed vision fixes (thesis sec. 8.2,
// eq. 8.6-8.12 with the errata; delayed fusion as in Oh et al., seed 003, errata form of S).
//
// Usage:
//   quad::est::PositionFilterParams p;                      // thesis table 8.1: Q = I2 T
//   quad::est::PositionFilter<quad::est::history_length(100)> kf(p);   // 100 Hz loop
//   every IMU sample (vehicle clock in microseconds):
//     kf.predict(quad::est::kinematic_acceleration(observer.dcm(), accel_frd), now_us);
//   when a vision fix arrives, with the time its image was captured (same clock):
//     kf.fuse_position(p_ned, capture_us);
//   or, where no iteration has room for the whole fusion, queue it and advance it one step per iteration
//   (gate, then update; predict() may run in between):
//     kf.queue_fix(p_ned, capture_us);  ...  if (kf.fix_in_progress()) kf.advance_fix();
//   kf.position(), kf.velocity()
//
// Each NED axis is its own filter with state (p, v), plus an acceleration bias b when enabled (v' = u - b):
// on z it is the accelerometer's bias along the vertical (an uncorrected one makes the height drift); on
// x and y it is the horizontal error of u, chiefly g times the observer's tilt error while it learns a
// gyro bias step (without it that error becomes a steady velocity error, which eq. 8.20's K_v turns into
// a position offset). Process noise is the continuous model whose Euler form is eq. 8.12,
// Q(T) = int_0^T Phi(t) diag(q_p, q_v, q_b) Phi(t)^T dt, discretised exactly so that it composes over
// any sequence of steps; the white-acceleration model is q_p = 0, q_v = sigma_a^2.
//
// Delayed fixes: the filter fuses a fix at its capture time s and carries the correction forward to
// now. With tau = now - s and Phi the constant-velocity transition, the covariance at s follows from the
// current one, P_s = Phi(-tau) (P_now - Q(tau)) Phi(-tau)^T, and the correction reaches now through
// Phi(tau): only the predicted position at s must be remembered. The history buffer therefore holds one
// 16-byte entry (time, position) per predict step; corrections fused after an entry was written are
// kept as one accumulated correction per axis, carried along to now with the state (c <- Phi(T) c at
// every predict), instead of rewriting the buffer. When that correction grows beyond a metre it is not
// added into the entries (26 of them at once: 68 000 cycles on the AVR) but starts an epoch: it is
// frozen, at the time of the newest entry, as the old-epoch correction, and the entries that were in the
// buffer then (the oldest old_epoch_entries()) get it added on lookup besides the current one, until
// they have left the buffer; a second fold within that window first adds the old one into them.
// Fixes older than the buffer, older than the last
// fused fix, or from before a reset are refused. The first fix initialises
// the filter at its capture time; a fix after 20 consecutive gate rejections or while the position
// sigma exceeds 5 m (dead reckoning through an outage) resets it the same way, keeping the velocity
// and the acceleration biases (they come from the IMU, not from the fix).
//
// Capacity: history_length(rate_hz) entries cover 250 ms at rate_hz (26 at 100 Hz: 416 bytes; 101 at
// 400 Hz). Fixes captured before the oldest entry are rejected as too old.
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace est {

// Entries that cover `window_ms` (default 250 ms) of history at a predict rate of rate_hz, plus one so
// that a fix captured exactly window_ms ago still has an entry at or before it. (32-bit arithmetic: int
// is 16 bits on the AVR.)
constexpr int history_length(int rate_hz, int window_ms = 250) {
  return static_cast<int>((static_cast<int32_t>(rate_hz) * window_ms + 999) / 1000 + 1);
}

// u = g e_z + R a_B   (thesis eq. 8.7): the kinematic acceleration in NED from the specific force.
Vec3 kinematic_acceleration(const Quat& q_ib, const Vec3& specific_force_frd);
// The same with R = R_IB given, e.g. ConditionedObserver::dcm(): nine multiplications instead of a
// quaternion rotation's fifteen (the AVR's loop uses this form).
Vec3 kinematic_acceleration(const Mat3& r_ib, const Vec3& specific_force_frd);

enum class ProcessNoise : uint8_t {
  kThesisDiagonal,     // eq. 8.12: q_p on position, q_v on velocity (table 8.1: both 1)
  kWhiteAcceleration,  // continuous white acceleration of spectral density q_accel (q_p = 0)
};

struct PositionFilterParams {
  ProcessNoise process_noise = ProcessNoise::kThesisDiagonal;
  float q_pos = 1.0f;        // sigma^2_{q,p}, m^2/s            (ThesisDiagonal)
  float q_vel = 1.0f;        // sigma^2_{q,v}, (m/s)^2/s        (ThesisDiagonal)
  float q_accel = 1.0f;      // sigma_a^2, (m/s^2)^2/Hz         (WhiteAcceleration)
  float fix_sigma_xy = 0.05f;  // sigma_r of a vision fix, horizontal, m   (eq. 8.12b)
  float fix_sigma_z = 0.05f;   // sigma_r of a vision fix, vertical, m
  bool z_accel_bias = false;   // estimate a constant accelerometer bias along NED z
  bool xy_accel_bias = false;  // estimate a constant acceleration error along NED x and y
  float q_bias = 1e-4f;        // z bias random walk, (m/s^2)^2/s (an accelerometer bias drifts slowly)
  // x/y bias random walk, (m/s^2)^2/s: a tilt error changes within seconds (the observer's bias mode), so
  // this state must follow it: 3e-2 learns a 0.2 m/s^2 step to 5 % in about 15 s with the thesis' Q.
  float q_bias_xy = 3e-2f;
  float bias_sigma0 = 0.3f;    // initial bias standard deviation, m/s^2
  float vel_sigma0 = 1.0f;     // initial velocity standard deviation, m/s
  float gate_sigma = 5.0f;     // a fix is rejected if any axis' innovation exceeds gate_sigma * sqrt(S)
  uint16_t reset_after_rejections = 20;  // consecutive rejections that make the next fix a reset (0: never)
  // A fix arriving while any axis' position standard deviation exceeds this (dead reckoning through a
  // vision outage) resets the filter to it: the state is lost, and a covariance that has grown for
  // minutes is beyond float precision in the delayed-fusion algebra.
  float reset_position_sigma = 5.0f;
};

enum class FixResult : uint8_t {
  kFused,               // used at its capture time
  kInitialized,         // first fix, or a reset (repeated rejections, or lost after an outage): position set to the fix
  kRejectedGate,        // innovation outside the Mahalanobis gate
  kRejectedTooOld,      // captured before the oldest history entry or before the last reset
  kRejectedOutOfOrder,  // captured before the last fused fix
  kRejectedInvalid,     // non-finite, or fused before the first predict
  kRejectedBusy,        // queue_fix() while another fix is still in progress
  kPending,             // queued, or gated and waiting for its update (queue_fix() / advance_fix())
};

struct PositionFilterHealth {
  uint32_t fused = 0;
  uint32_t rejected_gate = 0;   // outliers
  uint32_t rejected_too_old = 0;
  uint32_t rejected_out_of_order = 0;
  uint32_t rejected_invalid = 0;
  uint32_t resets = 0;
  uint32_t predict_skipped = 0;  // non-finite input or time not moving forward
  uint32_t rejected_busy = 0;    // queue_fix() while a fix was in progress
  uint32_t dropped_pending = 0;  // a fix in progress forgotten by a reset, new parameters or a gap
};

// Covariance of one axis: (p, v) or (p, v, b); symmetric, upper triangle stored.
struct AxisCovariance {
  float pp = 0.0f, pv = 0.0f, vv = 0.0f;
  float pb = 0.0f, vb = 0.0f, bb = 0.0f;
};

struct HistoryEntry {
  uint32_t t_us = 0;
  float p[3] = {0.0f, 0.0f, 0.0f};  // predicted position at t_us, less the accumulated correction
};

// The filter proper; the storage of its history buffer comes from PositionFilter<N> below.
class PositionFilterCore {
 public:
  void set_params(const PositionFilterParams& params);
  const PositionFilterParams& params() const { return params_; }

  // Sets the state at time t_us (position, velocity, bias zero) with the initial covariances and
  // forgets the history.
  void reset(const Vec3& p_ned, const Vec3& v_ned, uint32_t t_us);

  // Prediction to t_us with the kinematic acceleration u (thesis eq. 8.11a). The first call only starts
  // the clock. Steps longer than 0.5 s are taken as a gap: the state is propagated, the history cleared.
  void predict(const Vec3& u_ned, uint32_t t_us);

  // Fuses a NED position fix captured at capture_us (thesis eq. 8.11b with the errata, at capture time).
  FixResult fuse_position(const Vec3& p_ned, uint32_t capture_us);

  // The same fusion in two steps, for a loop with no iteration that has room for all of it (the
  // ATmega2560 at 400 Hz, docs/performance.md): queue_fix() takes the fix (Pending; RejectedBusy while
  // another is in progress); the first advance_fix() looks the capture time up, forms S and gates
  // (Pending when the fix passed, else its result); the second applies the gain to the covariance and
  // the state (Fused). predict() may run in between: the correction D h is carried to the update's time
  // by Phi, which is exact (the prediction is linear and its covariance does not depend on the state).
  // Back to back the two steps are fuse_position() operation for operation (bit-identical).
  FixResult queue_fix(const Vec3& p_ned, uint32_t capture_us);
  FixResult advance_fix();
  bool fix_in_progress() const { return fix_stage_ != kFixIdle; }
  // A fix was offered (whatever its result) within the history window: fuse_still() waits.
  bool fixes_arriving() const { return have_offered_; }

  // The vehicle stands still on the ground (ground_hold.h): zero velocity and the held position p_hold
  // fused at the current time as two scalar measurements per axis, thesis eq. 8.11b (errata) with
  // H = (0, 1[, 0]), R = sigma_v^2, then H = (1, 0[, 0]), R = sigma_p^2 (an extension: the thesis fuses
  // only vision fixes). The corrections join the accumulated one like a fix's, so later delayed fixes
  // still see a consistent history. Nothing (false) before the filter is initialised or while a fix is in
  // progress (its D h belongs to the covariance it was gated with), nor while fixes arrive (one offered
  // within the history window); a fix captured before the last still measurement is refused as out of
  // order (the delayed fusion's P_now - Q(tau) would not hold).
  bool fuse_still(const Vec3& p_hold, float sigma_p, float sigma_v);
  // The vehicle has come to rest on the ground but the hold's still time has not passed yet
  // (ground_hold.h): under fuse_still()'s conditions, the velocity is reset to zero with variance
  // sigma_v^2 and no correlation with the position or the bias; the position stays where it is.
  bool fuse_zero_velocity(float sigma_v);
  // The vehicle cannot be below the floor: when the position's down coordinate is beyond z_floor (the
  // vehicle's centre standing on the floor), the position is projected onto it (down z_floor), the
  // velocity and the covariance unchanged (the projection method of constrained Kalman filtering).
  // Only while no fix arrives (fixes hold the estimate; their history stays consistent: the projection
  // joins the accumulated correction like an update). Returns whether it projected.
  bool constrain_above_floor(float z_floor);
  // Before any fix: the state set at p (velocity zero, biases zero) at the current time, with the
  // position standard deviation of the fixes; the first fix is then an ordinary, gated update.
  void initialize_at(const Vec3& p);

  Vec3 position() const { return {x_[0].p, x_[1].p, x_[2].p}; }
  Vec3 velocity() const { return {x_[0].v, x_[1].v, x_[2].v}; }
  float accel_bias_z() const { return x_[2].b; }  // m/s^2; 0 unless z_accel_bias
  // The acceleration bias of every axis (m/s^2, NED); zero on the axes without a bias state.
  Vec3 accel_bias() const { return {x_[0].b, x_[1].b, x_[2].b}; }
  // x and y share one model, noise and the fusion instants, so their covariances are identical: one is
  // kept (and computed) for both. When z has the same fix noise and the same bias choice as x and y
  // (the defaults), its covariance is identical too and the one class serves all three axes.
  const AxisCovariance& covariance(int axis) const { return p_[covariance_class(axis)]; }
  // Kalman gain of the last fused fix on each axis (position, velocity), at the fix's capture time.
  float last_gain_p(int axis) const;
  float last_gain_v(int axis) const;
  // Normalised innovation squared of the last fix that reached the gate, summed over the axes.
  float last_nis() const { return last_d2_[0] + last_d2_[1] + last_d2_[2]; }
  // The last gated fix's innovation test ratios (ESTIMATOR_STATUS), nu^2 / (gamma^2 S) per axis: the
  // larger of x and y, and z (above 1 the fix was refused).
  float test_ratio_horizontal() const;
  float test_ratio_vertical() const;
  bool initialized() const { return initialized_; }
  uint32_t time_us() const { return t_us_; }
  const PositionFilterHealth& health() const { return health_; }
  // History entries (the oldest ones) from before the last fold of the accumulated correction, which get
  // the old-epoch correction on lookup (0: no old epoch). Diagnostics and tests.
  uint16_t old_epoch_entries() const { return old_epoch_left_; }

 protected:
  PositionFilterCore(HistoryEntry* storage, uint16_t capacity, const PositionFilterParams& params);
  PositionFilterCore(const PositionFilterCore&) = delete;
  PositionFilterCore& operator=(const PositionFilterCore&) = delete;

 private:
  struct AxisState {
    float p = 0.0f, v = 0.0f, b = 0.0f;
  };
  struct Correction {  // accumulated correction, expressed at the current time t_us_
    float p = 0.0f, v = 0.0f, b = 0.0f;
  };
  struct FrozenCorrection {  // the old epoch's (no initialisers: AVR flash; set at every fold)
    float p, v, b;
  };

  // Index into p_, q_ and gain_ of an axis' covariance class: 0 for x and y, 1 for z unless z shares.
  int covariance_class(int axis) const { return axis == 2 && !z_shares_xy_covariance_ ? 1 : 0; }
  int class_count() const { return z_shares_xy_covariance_ ? 1 : 2; }
  // Whether an axis, or a covariance class, carries the bias state; where it does not, b and its
  // corrections stay zero.
  bool has_bias(int axis) const { return axis == 2 ? params_.z_accel_bias : params_.xy_accel_bias; }
  bool class_has_bias(int c) const { return c == 0 ? params_.xy_accel_bias : params_.z_accel_bias; }
  // Spectral densities of position, velocity and, per covariance class, the bias (0 if it has none).
  bool white() const { return params_.process_noise == ProcessNoise::kWhiteAcceleration; }
  float qp() const { return white() ? 0.0f : params_.q_pos; }
  float qv() const { return white() ? params_.q_accel : params_.q_vel; }
  float qb(int c) const {
    return !class_has_bias(c) ? 0.0f : c == 0 ? params_.q_bias_xy : params_.q_bias;
  }
  void update_class_sharing();
  void push_history();
  void clear_history();
  void fold_correction();
  void fold_old_epoch();
  bool predicted_position_at(uint32_t t_us, float out[3], float h1, float h2);
  float correction_position(int axis, float dt) const;
  void initialize_from_fix(const Vec3& p_ned, uint32_t capture_us);
  void set_step(int32_t step_us);
  bool fix_resets() const;
  void capture_gain_terms(float tau, float h1, float h2, float w[2][3]);
  bool within_gate(const Vec3& y, const float p_s[3], float nu[3]);
  void propagate(const Vec3& u, int32_t step_us);
  FixResult accept_fix(const Vec3& p_ned);  // the checks of every fix: Pending when it may go on
  FixResult gate_fix(const Vec3& p_ned, uint32_t capture_us);
  FixResult update_fix();
  void drop_fix();
  // Adds k nu to axis i's state and accumulated correction; true when the correction has outgrown the
  // fold threshold.
  bool correct_axis(int i, const float k[3], float nu);
  // One scalar measurement y_i of state component m (0 position, 1 velocity) on every axis, now.
  void update_now(int m, const Vec3& y, float r);

  PositionFilterParams params_;
  // q_step_us_ is set by set_params() (from the constructor), q_dt_ .. h_dt_ with Q(q_dt_): no
  // initialisers (each is AVR flash in the constructor).
  int32_t q_step_us_;                        // step of the cached process noise (the loop period), us
  float q_dt_;                               // the same in seconds
  AxisCovariance q_[2];                      // Q(q_dt_): horizontal, vertical
  float half_dt_;                            // q_dt_ / 2
  float h_dt_;                               // q_dt_^2 / 2 (bias states only)
  AxisState x_[3];
  AxisCovariance p_[2];  // horizontal (x and y), vertical (p_[1] unused while z_shares_xy_covariance_)
  bool z_shares_xy_covariance_ = false;  // z's covariance is identical to x's and y's: one class
  Correction correction_[3];             // accumulated correction, carried to now (t_us_)
  // Correction of the old epoch, frozen at the time of its newest entry (the fold): valid while
  // old_epoch_left_ > 0.
  FrozenCorrection old_epoch_correction_[3];
  uint32_t inv_span_us_ = 0;                 // history spacing whose reciprocal inv_span_ holds (0: none)
  float inv_span_;
  // Last correction gain, carried to now; while a fix is gated (kFixGated) its D h, the gain times S.
  float gain_[2][3] = {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}};
  float gain_tau_ = 0.0f;                    // age of the last fused fix when it was fused
  float last_d2_[3] = {0.0f, 0.0f, 0.0f};  // the last gated fix's nu^2 / S per axis
  uint32_t t_us_ = 0;
  uint32_t last_fix_us_ = 0;    // capture time of the last fused fix (valid while have_fix_)
  bool clock_started_ = false;
  bool initialized_ = false;
  bool have_fix_ = false;
  uint32_t still_us_ = 0;     // the last still measurement (fuse_still), valid while have_still_
  bool have_still_ = false;
  uint32_t offered_us_ = 0;   // when the last fix was offered (any result), valid while have_offered_
  bool have_offered_ = false;
  uint16_t consecutive_rejections_ = 0;
  HistoryEntry* history_;
  uint16_t capacity_;
  uint16_t head_ = 0;   // index of the next entry to write
  uint16_t count_ = 0;  // valid entries
  uint16_t old_epoch_left_ = 0;  // the oldest old_epoch_left_ entries predate the last fold (old epoch; 0: none)
  // The fix in progress (queue_fix(), advance_fix()): queued, its position and capture time; gated, its
  // innovations, 1 / S per class and the time it was gated at (the same storage: the AVR's RAM).
  enum FixStage : uint8_t { kFixIdle, kFixQueued, kFixGated };
  FixStage fix_stage_ = kFixIdle;
  float fix_[3];        // queued: the fix; gated: its innovations nu
  uint32_t fix_us_;     // queued: its capture time; gated: the time it was gated at
  float fix_inv_s_[2];  // gated: 1 / S per covariance class
  PositionFilterHealth health_;
};

// The filter with its history buffer of kHistory entries (compile-time: no heap).
template <int kHistory>
class PositionFilter : public PositionFilterCore {
  static_assert(kHistory >= 2 && kHistory <= 65535, "history needs at least two entries");

 public:
  PositionFilter() : PositionFilter(PositionFilterParams{}) {}
  explicit PositionFilter(const PositionFilterParams& params)
      : PositionFilterCore(storage_, static_cast<uint16_t>(kHistory), params) {}

 private:
  HistoryEntry storage_[kHistory];
};

}  // namespace est
}  // namespace quad
