// Shared by the attitude filters: is this accelerometer sample a usable measurement of gravity?
#pragma once

#include "quad/math/math.h"

namespace quad {
namespace est {

// True when | |a|/g - 1 | < tolerance, tested on |a|^2 so that no square root is spent on rejects.
inline bool near_gravity(float accel_norm_sq, float tolerance) {
  if (!is_finite(accel_norm_sq)) return false;
  const float lo = maxf(1.0f - tolerance, 0.0f) * kGravity;
  const float hi = (1.0f + tolerance) * kGravity;
  return accel_norm_sq > lo * lo && accel_norm_sq < hi * hi;
}

}  // namespace est
}  // namespace quad
