#include "quad/control/setpoint_shaper.h"

namespace quad {
namespace ctrl {

namespace {

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
}

void SetpointShaper::reset(const Vec3& p) {
  p_ = p;
  v_ = Vec3{};
  target_ = p;
}

void SetpointShaper::update(float dt, PositionSetpoint& sp) {
  Vec3 a;
  if (dt > 0.0f && is_finite(dt) && is_finite(target_)) {
    const Vec3 to_target = target_ - p_;
    const float dist_sq = norm_sq(to_target);
    Vec3 v_cmd;
    if (dist_sq > 1e-12f) {  // beyond a micrometre (no square root spent while holding the target)
      const float dist = sqrtf(dist_sq);
      const float speed = minf(params_.max_speed, approach_speed(dist, params_.max_accel, params_.final_gain, linear_dist_));
      v_cmd = to_target * (speed / dist);
    }
    // The acceleration that reaches v_cmd in this step, no larger than max_accel.
    if (dt != dt_) {
      dt_ = dt;
      inv_dt_ = 1.0f / dt;
    }
    a = sat_delta((v_cmd - v_) * inv_dt_, params_.max_accel);
    const Vec3 v_next = v_ + a * dt;
    p_ += (v_ + v_next) * (0.5f * dt);  // exact for constant acceleration over the step
    v_ = v_next;
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
  if (!(is_finite(p.max_speed) && p.max_speed > 0.0f)) return "max_speed";
  if (!(is_finite(p.max_accel) && p.max_accel > 0.0f)) return "max_accel";
  if (!(is_finite(p.final_gain) && p.final_gain > 0.0f)) return "final_gain";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
