#include "quad/firmware/params.h"

#include <string.h>

#include "quad/firmware/flash.h"
#include "quad/firmware/storage_layout.h"
#include "quad/math/scalar.h"

namespace quad {
namespace fw {
namespace {

// The table in flash, built at compile time from QUAD_PARAM_TABLE: the names one after the other, each
// ended by a NUL, and per parameter the offset of its name and its default, minimum and maximum as
// indices into one pool of the distinct values (54 floats for 86 parameters' 258 values): 1 586 bytes
// instead of 86 ParamInfo records' 2 494. tests/firmware/test_params.cpp ("EveryEntryIsExactlyTheTableRow")
// compares every entry, bit for bit, with the table.

// Every value in table order: default, min, max of parameter 0, then of parameter 1, ...
constexpr float kAllValues[] = {
#define QUAD_PARAM_VALUES(id, name, def, lo, hi) def, lo, hi,
    QUAD_PARAM_TABLE(QUAD_PARAM_VALUES)
#undef QUAD_PARAM_VALUES
};
constexpr uint16_t kValueCount = sizeof kAllValues / sizeof kAllValues[0];

// Compile time only (never stored): the distinct values in order of first use, and each value's place
// among them. Values compare with ==, so 0.0f and -0.0f would share a slot (the table holds no -0.0f; the
// bitwise test named above would catch one).
struct PoolBuild {
  float values[kValueCount];
  uint8_t index[kValueCount];
  uint16_t size;
};

constexpr PoolBuild build_pool() {
  PoolBuild p{};
  for (uint16_t i = 0; i < kValueCount; ++i) {
    uint16_t j = 0;
    while (j < p.size && !(p.values[j] == kAllValues[i])) ++j;
    if (j == p.size) p.values[p.size++] = kAllValues[i];
    p.index[i] = static_cast<uint8_t>(j);
  }
  return p;
}

constexpr PoolBuild kPoolBuild = build_pool();
static_assert(kPoolBuild.size <= 256, "more than 256 distinct parameter values: widen the indices");

struct ValuePool {
  float v[kPoolBuild.size];
};

constexpr ValuePool make_value_pool() {
  ValuePool out{};
  for (uint16_t i = 0; i < kPoolBuild.size; ++i) out.v[i] = kPoolBuild.values[i];
  return out;
}

constexpr ValuePool kValuePool QUAD_FLASH = make_value_pool();

// Every name followed by a NUL, one after the other (940 bytes, not 86 x 17).
constexpr char kNames[] QUAD_FLASH =
#define QUAD_PARAM_NAME(id, name, def, lo, hi) name "\0"
    QUAD_PARAM_TABLE(QUAD_PARAM_NAME)
#undef QUAD_PARAM_NAME
    ;

// Compile time only: where the name of parameter `index` starts in kNames.
constexpr uint16_t name_offset(uint8_t index) {
  uint16_t at = 0;
  for (uint8_t i = 0; i < index; ++i) {
    while (kNames[at] != '\0') ++at;
    ++at;
  }
  return at;
}

struct ParamEntry {
  uint16_t name;  // offset in kNames
  uint8_t default_index;
  uint8_t min_index;
  uint8_t max_index;
};

constexpr ParamEntry kTable[kParamCount] QUAD_FLASH = {
#define QUAD_PARAM_ENTRY(id, name, def, lo, hi) \
  {name_offset(id), kPoolBuild.index[3 * (id)], kPoolBuild.index[3 * (id) + 1], kPoolBuild.index[3 * (id) + 2]},
    QUAD_PARAM_TABLE(QUAD_PARAM_ENTRY)
#undef QUAD_PARAM_ENTRY
};

__attribute__((noinline)) float pool_value(uint8_t index) {
  float v;
  flash_copy(&v, &kValuePool.v[index], sizeof v);
  return v;
}

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
  ParamEntry e;
  flash_copy(&e, &kTable[index < kParamCount ? index : 0], sizeof e);
  ParamInfo info;
  memset(info.name, 0, sizeof info.name);
  const char* name = kNames + e.name;
  for (uint8_t i = 0; i < kParamNameLength; ++i) {
    const char c = flash_char(name + i);
    if (c == '\0') break;
    info.name[i] = c;
  }
  info.default_value = pool_value(e.default_index);
  info.min = pool_value(e.min_index);
  info.max = pool_value(e.max_index);
  return info;
}

int16_t param_find(const char* name) {
  // The names in table order: compare each with the first 16 characters of `name` (strncmp semantics).
  const char* stored = kNames;
  for (uint8_t i = 0; i < kParamCount; ++i) {
    uint8_t n = 0;
    while (n < kParamNameLength && flash_char(stored + n) == name[n] && name[n] != '\0') ++n;
    if (n == kParamNameLength || (flash_char(stored + n) == '\0' && name[n] == '\0')) return i;
    while (flash_char(stored) != '\0') ++stored;
    ++stored;
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
