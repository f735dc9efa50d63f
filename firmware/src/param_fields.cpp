#include "quad/firmware/param_fields.h"

#include <string.h>

namespace quad {
namespace fw {

__attribute__((noinline)) void load_fields(const Params& p, void* dst, const ParamField* table, uint8_t n) {
  uint8_t* const base = static_cast<uint8_t*>(dst);
  for (uint8_t i = 0; i < n; ++i) {
    ParamField f;
    flash_copy(&f, &table[i], sizeof f);
    const float v = p.get(f.id);
    memcpy(base + f.offset, &v, sizeof v);
  }
}

}  // namespace fw
}  // namespace quad
