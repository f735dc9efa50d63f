// Internal: angle wrapping that is safe for any finite input. quad::wrap_pi() steps by 2 pi, which
// never terminates for |a| so large that a - 2 pi rounds back to a; fmodf first brings such angles
// into range.
#pragma once

#include "quad/math/scalar.h"

namespace quad {
namespace ctrl {

inline float wrap_heading(float a) {
  if (!is_finite(a)) return 0.0f;
  if (absf(a) > 4.0f * kPi) a = fmodf(a, kTwoPi);
  return wrap_pi(a);
}

}  // namespace ctrl
}  // namespace quad
