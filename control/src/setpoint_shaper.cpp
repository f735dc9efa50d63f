#include "quad/control/setpoint_shaper.h"

#include "quad/control/approx.h"

namespace quad {
namespace ctrl {

namespace {

constexpr float kArrivalDistSq = 1e-8f;  // (0.1 mm)^2

// v exactly +0 in every component (bit pattern zero; -0 does not count, a step would turn it into +0).
__attribute__((noinline)) bool is_exactly_zero(const Vec3& v) {
  uint32_t x, y, z;
  memcpy(&x, &v.x, sizeof x);
  memcpy(&y, &v.y, sizeof y);
  memcpy(&z, &v.z, sizeof z);
  return (x | y | z) == 0u;
}

// Speed towards a target `dist` metres away that can still brake to rest at `accel` (the square-root
// law v = sqrt(2 a d)), blended into a linear law v = k d near the target where the two have the same
// slope (d <= a / k^2 = linear_dist), so the velocity command is continuous and differentiable.
float approach_speed(float dist, float accel, float k, float linear_dist) {
  if (dist <= linear_dist) return k * dist;
  return sqrtf(2.0f * accel * (dist - 0.5f * linear_dist));
}

}  // namespace

void SetpointShaper::set_params(const ShaperParams& p) {
  params_ = p;
  linear_dist_ = p.max_accel / (p.final_gain * p.final_gain);
  // Beyond this distance approach_speed() >= max_speed, so the commanded speed is max_speed without its
  // square root: sqrt(2 a (d - d_l/2)) >= v_max for d >= v_max^2 / (2 a) + d_l / 2, and in the linear
  // range k d >= v_max there too (v_max^2/(2a) + a/(2k^2) >= v_max/k). The factor 1 + 1e-5 is far above
  // the round-off of the square-root law (a few 1e-7), so the result is exactly what min() would give.
  cruise_dist_ = (p.max_speed * p.max_speed / (2.0f * p.max_accel) + 0.5f * linear_dist_) * 1.00001f;
  holding_ = false;
}

void SetpointShaper::reset(const Vec3& p) {
  p_ = p;
  v_ = Vec3{};
  target_ = p;
  holding_ = false;  // (the first update() confirms the hold)
}

void SetpointShaper::update(float dt, PositionSetpoint& sp) {
  Vec3 a;
  // Holding (v = 0 and the target within a micrometre): the step below would give v_cmd = 0, a = 0 and
  // leave v and p as they are (p + 0 = p), and so does an unusable dt. Nothing to do.
  if (!holding_ && dt > 0.0f && is_finite(dt) && is_finite(target_)) {
    const Vec3 to_target = target_ - p_;
    const float dist_sq = norm_sq(to_target);
    Vec3 v_cmd;
    bool within_um = true;
    if (dist_sq > 1e-12f) {  // beyond a micrometre (no square root spent while holding the target)
      within_um = false;
      const float dist = sqrtf(dist_sq);
      const float speed =
          dist >= cruise_dist_
              ? params_.max_speed
              : minf(params_.max_speed, approach_speed(dist, params_.max_accel, params_.final_gain, linear_dist_));
      v_cmd = to_target * (speed / dist);
    }
    // The acceleration that reaches v_cmd in this step, no larger than max_accel.
    if (dt != dt_) {
      dt_ = dt;
      inv_dt_ = 1.0f / dt;
    }
    a = sat_delta((v_cmd - v_) * inv_dt_, params_.max_accel);
    const bool was_at_rest = is_exactly_zero(v_);
    if (dist_sq <= kArrivalDistSq && norm_sq(v_) * (inv_dt_ * inv_dt_) <= params_.max_accel * params_.max_accel) {
      // Arrival: within 0.1 mm and able to stop in this step, the reference lands on the target at rest.
      // Closer in, the linear law's steps k d dt fall below the float resolution of p at metre scale
      // (1.2e-7 m at 1.5 m): without this step the approach would stall micrometres short, with a velocity
      // of about 1e-5 m/s that does not move p, and never hold (every later step computed in full).
      a = (Vec3{} - v_) * inv_dt_;  // the stop (+0 at rest, as the hold gives)
      p_ = target_;
      v_ = Vec3{};
    } else {
      const Vec3 v_next = v_ + a * dt;
      p_ += (v_ + v_next) * (0.5f * dt);  // exact for constant acceleration over the step
      v_ = v_next;
    }
    // At rest before and after within a micrometre: p did not move, so the next step is this one again.
    holding_ = within_um && was_at_rest && is_exactly_zero(v_);
  }
  sp.p_d = p_;
  sp.v_d = v_;
  sp.a_d = a;
}

bool SetpointShaper::arrived(float tolerance) const {
  return norm_sq(target_ - p_) <= tolerance * tolerance &&
         norm_sq(v_) <= sqf(params_.final_gain * tolerance);
}

const char* validate(const ShaperParams& p) {
  if (!positive_finite(p.max_speed)) return "max_speed";
  if (!positive_finite(p.max_accel)) return "max_accel";
  if (!positive_finite(p.final_gain)) return "final_gain";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
