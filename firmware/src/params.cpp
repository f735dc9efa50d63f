#include "quad/firmware/params.h"

#include <string.h>

#include "quad/firmware/flash.h"
#include "quad/link/crc.h"
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

constexpr uint16_t kMagic = 0x5051;  // "QP"
constexpr uint16_t kLayoutVersion = 1;

struct Header {
  uint16_t magic;
  uint16_t version;
  uint16_t schema;
  uint16_t count;
};
constexpr uint16_t kHeaderSize = sizeof(Header);
constexpr uint16_t kValuesOffset = kHeaderSize;
constexpr uint16_t kCrcOffset = kValuesOffset + kParamCount * sizeof(float);

uint16_t values_crc(const Params& params) {
  uint16_t crc = mavlink::kCrcInit;
  for (uint8_t i = 0; i < kParamCount; ++i) {
    const float v = params.get(i);
    crc = mavlink::crc_accumulate(reinterpret_cast<const uint8_t*>(&v), sizeof v, crc);
  }
  return crc;
}

Header current_header() { return Header{kMagic, kLayoutVersion, params_schema_hash(), kParamCount}; }

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

uint16_t params_store_size() { return kCrcOffset + sizeof(uint16_t); }

StoreStatus params_load(const StorageIo& io, Params& params) {
  params.reset_to_defaults();
  Header header;
  if (!io.read(0, &header, sizeof header)) return StoreStatus::kIoError;
  if (header.magic == 0xFFFF && header.version == 0xFFFF) return StoreStatus::kEmpty;
  const Header expected = current_header();
  if (header.magic != expected.magic || header.version != expected.version) return StoreStatus::kCorrupt;
  if (header.schema != expected.schema || header.count != expected.count) return StoreStatus::kSchemaChanged;

  Params loaded;
  for (uint8_t i = 0; i < kParamCount; ++i) {
    float v;
    if (!io.read(static_cast<uint16_t>(kValuesOffset + i * sizeof(float)), &v, sizeof v)) return StoreStatus::kIoError;
    if (loaded.set(i, v) != ParamError::kNone) return StoreStatus::kCorrupt;
  }
  uint16_t crc;
  if (!io.read(kCrcOffset, &crc, sizeof crc)) return StoreStatus::kIoError;
  if (crc != values_crc(loaded)) return StoreStatus::kCorrupt;
  for (uint8_t i = 0; i < kParamCount; ++i) params.set(i, loaded.get(i));
  return StoreStatus::kLoaded;
}

bool params_save_all(const StorageIo& io, const Params& params) {
  const Header header = current_header();
  if (!io.write(0, &header, sizeof header)) return false;
  for (uint8_t i = 0; i < kParamCount; ++i) {
    const float v = params.get(i);
    if (!io.write(static_cast<uint16_t>(kValuesOffset + i * sizeof(float)), &v, sizeof v)) return false;
  }
  const uint16_t crc = values_crc(params);
  return io.write(kCrcOffset, &crc, sizeof crc);
}

bool params_save_one(const StorageIo& io, const Params& params, uint8_t index) {
  if (index >= kParamCount) return false;
  Header header;
  const Header expected = current_header();
  // A store that is not ours yet (first save after defaults) is written whole.
  if (!io.read(0, &header, sizeof header) || memcmp(&header, &expected, sizeof header) != 0) {
    return params_save_all(io, params);
  }
  const float v = params.get(index);
  const uint16_t crc = values_crc(params);
  return io.write(static_cast<uint16_t>(kValuesOffset + index * sizeof(float)), &v, sizeof v) &&
         io.write(kCrcOffset, &crc, sizeof crc);
}

}  // namespace fw
}  // namespace quad
