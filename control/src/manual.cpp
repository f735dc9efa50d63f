#include "quad/control/manual.h"

#include "quad/control/approx.h"
#include "angle.h"

namespace quad {
namespace ctrl {

namespace {
constexpr int kMidPulse = 1500;
constexpr int kHalfRange = 500;  // us from mid stick to full deflection

int effective_band(uint16_t dead_band) { return dead_band < kHalfRange ? dead_band : kHalfRange - 1; }

// stick_to_unit() with 1 / (500 - band) given.
float stick_unit(uint16_t pulse_us, int band, float scale) {
  const int d = static_cast<int>(pulse_us) - kMidPulse;
  const int mag = d < 0 ? -d : d;
  if (mag <= band) return 0.0f;
  const float u = minf(static_cast<float>(mag - band) * scale, 1.0f);
  return d < 0 ? -u : u;
}

}  // namespace

float stick_to_unit(uint16_t pulse_us, uint16_t dead_band) {
  const int band = effective_band(dead_band);
  return stick_unit(pulse_us, band, 1.0f / static_cast<float>(kHalfRange - band));
}

float throttle_to_unit(uint16_t pulse_us) {
  return clampf(static_cast<float>(static_cast<int>(pulse_us) - 1000) * 1e-3f, 0.0f, 1.0f);
}

void ManualControl::set_params(const ManualParams& p) {
  params_ = p;
  stick_scale_ = 1.0f / static_cast<float>(kHalfRange - effective_band(p.dead_band));
}

void ManualControl::reset(float yaw) {
  const float half = 0.5f * wrap_heading(yaw);
  yaw_half_c_ = cosf(half);
  yaw_half_s_ = sinf(half);
  command_ = AttitudeCommand{};
  command_.q_d = Quat{yaw_half_c_, 0.0f, 0.0f, yaw_half_s_};
}

float ManualControl::heading() const { return wrap_pi(2.0f * atan2f(yaw_half_s_, yaw_half_c_)); }

bool ManualControl::update(const RcSticks& rc, float dt) {
  const uint16_t lo = params_.min_pulse;
  const uint16_t hi = params_.max_pulse;
  if (rc.roll < lo || rc.roll > hi || rc.pitch < lo || rc.pitch > hi || rc.yaw < lo || rc.yaw > hi ||
      rc.throttle < lo || rc.throttle > hi || !is_finite(dt) || dt < 0.0f) {
    return false;
  }

  const int band = effective_band(params_.dead_band);
  const float roll_unit = stick_unit(rc.roll, band, stick_scale_);
  const float pitch_unit = stick_unit(rc.pitch, band, stick_scale_);
  const float yaw_unit = stick_unit(rc.yaw, band, stick_scale_);
  const float roll = params_.max_angle * (params_.reverse_roll ? -roll_unit : roll_unit);
  const float pitch = params_.max_angle * (params_.reverse_pitch ? -pitch_unit : pitch_unit);
  const float yaw_rate = params_.max_yaw_rate * (params_.reverse_yaw ? -yaw_unit : yaw_unit);

  // Sec. 6.1.4: the yaw stick is a rate. Turn the held half-heading by half of yaw_rate dt, a rotation
  // of the unit pair (cos, sin); one Newton step on the norm keeps it unit without a square root. The
  // step is limited to the range of sincos_small (0.4 rad: dt up to 0.4 s at 2 rad/s).
  const SinCos step = sincos_small(clampf(0.5f * yaw_rate * dt, -0.4f, 0.4f));
  const float c = yaw_half_c_ * step.c - yaw_half_s_ * step.s;
  const float s = yaw_half_s_ * step.c + yaw_half_c_ * step.s;
  const float renorm = 0.5f * (3.0f - (c * c + s * s));
  yaw_half_c_ = c * renorm;
  yaw_half_s_ = s * renorm;

  // thesis eq. 6.2 (ZYX Euler angles to quaternion), evaluated as the product it expands:
  // Q_d = Q_yaw (x) (Q_pitch (x) Q_roll), with Q_pitch (x) Q_roll = (cr cp, sr cp, cr sp, -sr sp).
  const SinCos r = sincos_small(0.5f * roll);
  const SinCos p = sincos_small(0.5f * pitch);
  const float w = r.c * p.c, x = r.s * p.c, y = r.c * p.s, z = -r.s * p.s;
  const float cy = yaw_half_c_;
  const float sy = yaw_half_s_;
  command_.q_d = Quat{cy * w - sy * z, cy * x - sy * y, cy * y + sy * x, cy * z + sy * w};
  command_.thrust = params_.max_thrust * throttle_to_unit(rc.throttle);
  command_.mu_applied = Vec3{};
  command_.limited = false;
  return true;
}

const char* validate(const ManualParams& p) {
  if (!(positive_finite(p.max_angle) && p.max_angle <= 45.0f * kDegToRad)) return "max_angle";
  if (!(positive_finite(p.max_yaw_rate) && p.max_yaw_rate <= kTwoPi)) return "max_yaw_rate";
  if (!positive_finite(p.max_thrust)) return "max_thrust";
  if (p.dead_band >= 200) return "dead_band";
  if (p.min_pulse > 1000) return "min_pulse";
  if (p.max_pulse < 2000) return "max_pulse";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
