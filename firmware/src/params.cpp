#include "quad/firmware/params.h"

#include <string.h>

#include "quad/firmware/flash.h"
#include "quad/firmware/storage_layout.h"
#include "quad/math/scalar.h"

namespace quad {
namespace fw {
namespace {

const ParamInfo kTable[kParamCount] QUAD_FLASH = {
#define QUAD_PARAM_INFO(id, name, def, lo, hi) {name, def, lo, hi},
    QUAD_PARAM_TABLE(QUAD_PARAM_INFO)
#undef QUAD_PARAM_INFO
};

// Every name fits MAVLink's 16-character param_id.
#define QUAD_PARAM_CHECK(id, name, def, lo, hi)                                           \
  static_assert(sizeof(name) - 1 <= kParamNameLength, "parameter name longer than 16"); \
  static_assert((lo) <= (def) && (def) <= (hi), "parameter default outside its range");
QUAD_PARAM_TABLE(QUAD_PARAM_CHECK)
#undef QUAD_PARAM_CHECK

// Bump when the store's layout changes (2: two redundant copies).
constexpr uint16_t kLayoutVersion = 2;

RecordLayout store_layout() {
  // The tag mixes the layout version into the schema hash: either change makes the store foreign.
  return RecordLayout{kParamsStoreOffset, kParamCount * sizeof(float),
                      static_cast<uint16_t>(params_schema_hash() ^ (kLayoutVersion * 0x9E37u))};
}

}  // namespace

ParamInfo param_info(uint8_t index) {
  ParamInfo info;
  flash_copy(&info, &kTable[index < kParamCount ? index : 0], sizeof info);
  return info;
}

int16_t param_find(const char* name) {
  for (uint8_t i = 0; i < kParamCount; ++i) {
    char stored[kParamNameLength + 1];
    flash_copy(stored, kTable[i].name, sizeof stored);
    if (strncmp(stored, name, kParamNameLength) == 0) return i;
  }
  return -1;
}

ParamError Params::set(uint8_t index, float value) {
  if (index >= kParamCount) return ParamError::kUnknownName;
  if (!is_finite(value)) return ParamError::kNotFinite;
  const ParamInfo info = param_info(index);
  if (value < info.min || value > info.max) return ParamError::kOutOfRange;
  values_[index] = value;
  ++generation_;
  return ParamError::kNone;
}

void Params::reset_to_defaults() {
  for (uint8_t i = 0; i < kParamCount; ++i) values_[i] = param_info(i).default_value;
  ++generation_;
}

FlashText store_status_text(StoreStatus status) {
  switch (status) {
    case StoreStatus::kLoaded: return QUAD_TEXT("params loaded");
    case StoreStatus::kEmpty: return QUAD_TEXT("params: store empty, defaults");
    case StoreStatus::kSchemaChanged: return QUAD_TEXT("params: table changed, defaults");
    case StoreStatus::kCorrupt: return QUAD_TEXT("params: store corrupt, defaults");
    case StoreStatus::kIoError: return QUAD_TEXT("params: storage error, defaults");
  }
  return QUAD_TEXT("params: ?");
}

// FNV-1a over the names, folded to 16 bits: a firmware with a different table never reads this one's
// values into the wrong slots.
uint16_t params_schema_hash() {
  uint32_t h = 2166136261u;
  for (uint8_t i = 0; i < kParamCount; ++i) {
    const ParamInfo info = param_info(i);
    for (uint8_t c = 0; c <= kParamNameLength && info.name[c] != '\0'; ++c) {
      h = (h ^ static_cast<uint8_t>(info.name[c])) * 16777619u;
    }
    h = (h ^ 0u) * 16777619u;  // separator, so "AB","C" differs from "A","BC"
  }
  return static_cast<uint16_t>((h >> 16) ^ (h & 0xFFFFu));
}

uint16_t params_store_size() { return record_footprint(kParamCount * sizeof(float)); }

StoreStatus params_load(const StorageIo& io, Params& params) {
  params.reset_to_defaults();
  float stored[kParamCount];
  switch (record_load(io, store_layout(), stored)) {
    case RecordStatus::kLoaded: break;
    case RecordStatus::kEmpty: return StoreStatus::kEmpty;
    case RecordStatus::kTagMismatch: return StoreStatus::kSchemaChanged;
    case RecordStatus::kCorrupt: return StoreStatus::kCorrupt;
    case RecordStatus::kIoError: return StoreStatus::kIoError;
  }
  // A complete record with a value outside today's range (a range narrowed by an update): defaults
  // rather than a half-old configuration.
  for (uint8_t i = 0; i < kParamCount; ++i) {
    if (params.set(i, stored[i]) != ParamError::kNone) {
      params.reset_to_defaults();
      return StoreStatus::kCorrupt;
    }
  }
  return StoreStatus::kLoaded;
}

bool params_save_all(const StorageIo& io, const Params& params) {
  return record_save(io, store_layout(), params.values());
}

}  // namespace fw
}  // namespace quad
