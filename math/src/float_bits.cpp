#include "quad/math/float_bits.h"

namespace quad {

#if defined(QUAD_TARGET_AVR)
__attribute__((noinline))  // one copy for every caller (flash)
#endif
float exact_half(float x) {
  const uint32_t b = float_bits(x);
  const uint32_t e = b & kFloatInfBits;
  if (e > 0x00800000u && e != kFloatInfBits) return float_of_bits(b - 0x00800000u);  // exponent field 2..254
  return 0.5f * x;
}

}  // namespace quad
