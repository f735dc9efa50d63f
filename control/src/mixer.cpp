#include "quad/control/mixer.h"

#include "quad/math/float_bits.h"

namespace quad {
namespace ctrl {

namespace {

// -1, 0 or +1: zero when |x| is negligible against the scale (the plus frame's zero arms).
int8_t sign_of(float x, float scale) {
  if (absf(x) < 1e-6f * scale) return 0;
  return x > 0.0f ? 1 : -1;
}

// sign * g and x + sign * g without a multiplication (float multiplications are software on the AVR).
float signed_term(int8_t sign, float g) { return sign > 0 ? g : (sign < 0 ? -g : 0.0f); }
float add_signed(float x, int8_t sign, float g) { return sign > 0 ? x + g : (sign < 0 ? x - g : x); }

// Range tests on normalised motor thrusts by their bit patterns (float_bits.h: 1 070 cycles off the longest
// iteration of the 200 Hz PIL flight): a non-negative float orders like its bits as an unsigned integer,
// and every negative float (sign bit set) is above every non-negative one. Exact for every float but
// NaN (the inputs are checked finite, and no step makes a NaN of them); -0 counts as 0, as the float
// comparisons do.
bool in_unit(float x) {  // 0 <= x && x <= 1
  const uint32_t u = float_bits(x);
  return u <= 0x3F800000u || u == 0x80000000u;  // up to 1.0f, or -0
}
// The round-off slack of the final check: 8 ulps of 1 (2^-20 = 9.5e-7) either side of [0, 1].
bool within_slack(float x) {  // -2^-20 <= x && x <= 1 + 2^-20
  const uint32_t u = float_bits(x);
  return u <= 0x3F800008u || (u >= 0x80000000u && u <= 0xB5800000u);
}
// clampf(x, 0, 1) with -0 made +0, on the bit patterns (the square root of the command keeps the sign of a zero).
float clamp_unit(float x) { return positive(x) ? (abs_below(x, 1.0f) ? x : 1.0f) : 0.0f; }

}  // namespace

Mixer::Mixer() { set_vehicle(VehicleParams{}); }

Mixer::Mixer(const VehicleParams& v) { set_vehicle(v); }

void Mixer::set_vehicle(const VehicleParams& v) {
  const float f_max = v.max_motor_thrust;
  collective_gain_ = 0.25f / f_max;
  thrust_full_ = 4.0f * f_max;
  w_sq_max_ = f_max / v.thrust_coeff;
  const float yaw_per_thrust = v.yaw_coeff / v.thrust_coeff;  // kappa / b, m
  // Per axis (roll, pitch, yaw): the column's squared norm, its entries' magnitude and signs. (Loops over
  // the axes rather than written out: set-up code, kept small.)
  float sq[3] = {0.0f, 0.0f, 0.0f}, mag[3] = {0.0f, 0.0f, 0.0f};
  int8_t* const signs[3] = {roll_sign_, pitch_sign_, yaw_sign_};
  const float scale[3] = {v.arm_length, v.arm_length, yaw_per_thrust};
  for (int i = 0; i < kMotorCount; ++i) {
    const MotorLayout m = motor_layout(v.frame, v.arm_length, i);
    // Forward factors, thesis eq. 5.4/5.6 in per-rotor form: the thrust f_i along body -z at (x_i, y_i)
    // gives the torque (x_i, y_i, 0) x (0, 0, -f_i) = (-y_i f_i, x_i f_i, 0), plus the drag torque.
    const float arm[3] = {-m.y, m.x, m.spin * yaw_per_thrust};
    for (int j = 0; j < 3; ++j) {
      sq[j] += arm[j] * arm[j];
      mag[j] = maxf(mag[j], absf(arm[j]));
      signs[j][i] = sign_of(arm[j], scale[j]);
    }
  }
  // Inverse, thesis eq. 5.8: the four columns of the forward map (thrust, roll, pitch, yaw) are
  // mutually orthogonal for both layouts, so each row of M^-1 is a column divided by its squared norm.
  // For the plus frame this gives exactly the entries (4b)^-1, (2db)^-1, (4 kappa)^-1 of eq. 5.8
  // (here in thrust units: f_i = b w_bar_i). Within a column the nonzero entries differ only in sign.
  // Normalised (n_i = f_i / f_max), the gains are divided by f_max once more.
  roll_gain_ = mag[0] / sq[0] / f_max;
  pitch_gain_ = mag[1] / sq[1] / f_max;
  const float yaw_gain = mag[2] / sq[2];
  yaw_gain_ = yaw_gain / f_max;
  yaw_torque_ = f_max / yaw_gain;
}

// n_i = (c + s_i yaw) + rp_i for every motor (eq. 5.8 in normalised thrust): two sums of c and the yaw
// share serve all four motors. Returns whether every n_i lies in [0, 1]. (Inlined into its three call
// sites: measured 65 cycles faster in the common case and 300-600 when desaturating, for 190 bytes.)
__attribute__((always_inline)) inline bool Mixer::spread(float c, const float rp[kMotorCount], float yaw,
                                                         float f[kMotorCount]) const {
  const float c_up = c + yaw, c_down = c - yaw;
  bool fits = true;
  for (int i = 0; i < kMotorCount; ++i) {
    f[i] = (yaw_sign_[i] > 0 ? c_up : (yaw_sign_[i] < 0 ? c_down : c)) + rp[i];
    fits = fits && in_unit(f[i]);
  }
  return fits;
}

// The largest yaw step (same sign as `yaw`, magnitude at most |yaw|) with 0 <= c + rp_i + s_i step <= 1
// on every motor, s_i the yaw column's sign (-1/0/+1); false if there is none. On entry f[i] holds the
// motor thrusts with the full yaw demand (spread()); on success it holds them with the step found. Only
// a motor that is out of range in the direction its yaw share pushes can bound the step, and then by
// its room 1 - (c + rp_i) (pushed up) or c + rp_i (pushed down): the step is the yaw demand capped at
// the least room, with no division (every yaw share has the magnitude |yaw|). The yaw column sums to
// zero and is orthogonal to roll and pitch, so the step changes neither thrust nor roll/pitch torque.
// (Its sign and range tests on the bit patterns, float_bits.h: about 1 000 cycles off the longest
// iteration of the 200 Hz PIL flight, a yaw-saturated one.)
bool Mixer::fit_yaw(float c, const float rp[kMotorCount], float yaw, float f[kMotorCount], float& step) const {
  const bool yaw_up = !negative(yaw);
  // The least room of the motors pushed up out of range is 1 - (c + max rp_i) over them, of those pushed
  // down c + min rp_i (float rounding is monotonic, so this is exactly the least of the per-motor rooms).
  bool up_bound = false, down_bound = false;
  float rp_up = 0.0f, rp_down = 0.0f;
  for (int i = 0; i < kMotorCount; ++i) {
    if (yaw_sign_[i] == 0) continue;
    if ((yaw_sign_[i] > 0) == yaw_up) {
      if (!above_nonnegative(f[i], 1.0f)) continue;
      rp_up = up_bound ? maxf(rp_up, rp[i]) : rp[i];
      up_bound = true;
    } else {
      if (!negative(f[i])) continue;
      rp_down = down_bound ? minf(rp_down, rp[i]) : rp[i];
      down_bound = true;
    }
  }
  step = yaw;
  if (!up_bound && !down_bound) {  // no motor bounds the step: f[] is already the full demand
    for (int i = 0; i < kMotorCount; ++i) {
      if (!in_unit(f[i])) return false;
    }
    return true;
  }
  float room = yaw_up ? yaw : -yaw;
  if (up_bound) room = minf(room, 1.0f - (c + rp_up));
  if (down_bound) room = minf(room, c + rp_down);
  if (negative(room)) room = 0.0f;
  step = yaw_up ? room : -room;
  spread(c, rp, step, f);
  for (int i = 0; i < kMotorCount; ++i) {
    // A slack of 8 float steps keeps round-off from declaring a feasible demand infeasible; the clamp
    // only absorbs that round-off.
    if (!within_slack(f[i])) return false;
    f[i] = clamp_unit(f[i]);
  }
  return true;
}

MixerOutput Mixer::mix(float thrust, const Vec3& torque) const {
  MixerOutput out;  // (returned in place: no copy, and no temporary in the caller's frame)
  mix(thrust, torque, out);
  return out;
}

void Mixer::mix(float thrust, const Vec3& torque, MixerOutput& out) const {
  if (!is_finite(thrust) || !is_finite(torque)) {
    out = MixerOutput{};  // all motors at zero
    out.yaw_limited = out.thrust_limited = out.roll_pitch_limited = true;
    return;
  }
  out.yaw_limited = out.thrust_limited = out.roll_pitch_limited = false;

  // Per-motor normalised thrust shares of the demand (eq. 5.8): n_i = c + rp_i + s_i yaw, with the
  // collective share c = T / (4 f_max).
  const float roll = roll_gain_ * torque.x;
  const float pitch = pitch_gain_ * torque.y;
  const float yaw = yaw_gain_ * torque.z;
  const float wanted = collective_gain_ * thrust;
  float rp[kMotorCount];
  float* const f = out.share;  // the shares are worked out in place
  for (int i = 0; i < kMotorCount; ++i) {
    // (On the plus frame each motor has only a roll or only a pitch arm: no addition.)
    rp[i] = roll_sign_[i] == 0 ? signed_term(pitch_sign_[i], pitch)
                               : add_signed(signed_term(roll_sign_[i], roll), pitch_sign_[i], pitch);
  }

  out.achieved.thrust = thrust;
  out.achieved.torque = torque;
  // The common case, decided without a division or a float comparison.
  if (!spread(wanted, rp, yaw, f)) {
    float step = yaw;
    if (!fit_yaw(wanted, rp, yaw, f, step)) {
      // Thrust with roll/pitch does not fit for any yaw fraction in [0, 1].
      float rp_lo = rp[0], rp_hi = rp[0];
      for (int i = 1; i < kMotorCount; ++i) {
        rp_lo = minf(rp_lo, rp[i]);
        rp_hi = maxf(rp_hi, rp[i]);
      }
      // Priority 1: roll/pitch alone must fit between 0 and 1 (f_max) on every motor.
      const float rp_spread = rp_hi - rp_lo;
      if (rp_spread > 1.0f) {
        const float rp_scale = 1.0f / rp_spread;
        for (int i = 0; i < kMotorCount; ++i) rp[i] *= rp_scale;
        rp_lo *= rp_scale;
        rp_hi *= rp_scale;
        out.roll_pitch_limited = true;
        out.achieved.torque.x = torque.x * rp_scale;
        out.achieved.torque.y = torque.y * rp_scale;
      }
      // Priority 2: shift the collective share as little as possible so that roll/pitch fit (without
      // yaw); priority 3: then whatever yaw fits in the room left.
      const float collective = clampf(wanted, -rp_lo, 1.0f - rp_hi);
      if (collective != wanted) {
        out.thrust_limited = true;
        out.achieved.thrust = collective * thrust_full_;
      }
      spread(collective, rp, yaw, f);
      if (!fit_yaw(collective, rp, yaw, f, step)) {
        // Only round-off can get here (roll/pitch were made to fit around the collective): no yaw.
        step = 0.0f;
        out.yaw_limited = true;
        for (int i = 0; i < kMotorCount; ++i) f[i] = clamp_unit(collective + rp[i]);
      }
    }
    // By the orthogonality of the columns, what the motors now produce (eq. 5.5) is the demand with the
    // collective shifted and the torque axes scaled (tested against the forward model). The yaw torque
    // of a step is the step over the normalised yaw gain.
    if (step != yaw) {
      out.yaw_limited = true;
      out.achieved.torque.z = step * yaw_torque_;
    }
  }

  for (int i = 0; i < kMotorCount; ++i) out.command[i] = sqrtf(f[i]);  // u_i = w_i / w_max = sqrt(n_i) (vehicle.h)
}

Wrench Mixer::forward(const float share[kMotorCount]) const {
  // thesis eq. 5.5: (T, tau) = M w_bar, evaluated per rotor with f_i = b w_bar_i (eq. 5.3). The mixer
  // keeps only its inverse, so the forward factors come from it: the nonzero factors of an axis share
  // one magnitude |arm|, and its inverse gain (normalised) is 1 / (m |arm| f_max) for the m motors with
  // a nonzero factor. So tau_axis = sum(s_i n_i) / (m gain), T = f_max sum n_i.
  // (Not on the flight path: a few divisions are fine here.)
  float thrust = 0.0f, roll = 0.0f, pitch = 0.0f, yaw = 0.0f;
  int roll_count = 0, pitch_count = 0, yaw_count = 0;
  for (int i = 0; i < kMotorCount; ++i) {
    const float n = share[i];
    thrust += n;
    roll = add_signed(roll, roll_sign_[i], n);
    pitch = add_signed(pitch, pitch_sign_[i], n);
    yaw = add_signed(yaw, yaw_sign_[i], n);
    roll_count += roll_sign_[i] != 0;
    pitch_count += pitch_sign_[i] != 0;
    yaw_count += yaw_sign_[i] != 0;
  }
  Wrench w;
  w.thrust = thrust * (0.25f * thrust_full_);
  w.torque = Vec3{roll / (static_cast<float>(roll_count) * roll_gain_),
                  pitch / (static_cast<float>(pitch_count) * pitch_gain_),
                  yaw / (static_cast<float>(yaw_count) * yaw_gain_)};
  return w;
}

}  // namespace ctrl
}  // namespace quad
