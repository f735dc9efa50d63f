// Fuzz target: the parameter store decoder. The input is the content of the storage (EEPROM or file).
// Whatever it holds, loading must end with every parameter finite and inside its range, and a store
// reported as loaded must survive a save/load round trip unchanged.
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "quad/firmware/params.h"

namespace {

namespace fw = quad::fw;

uint8_t g_store[4096];
uint16_t g_size = 0;

bool store_read(uint16_t offset, void* dst, uint16_t length) {
  if (static_cast<uint32_t>(offset) + length > g_size) return false;
  memcpy(dst, g_store + offset, length);
  return true;
}
bool store_write(uint16_t offset, const void* src, uint16_t length) {
  if (static_cast<uint32_t>(offset) + length > sizeof g_store) return false;
  memcpy(g_store + offset, src, length);
  if (offset + length > g_size) g_size = static_cast<uint16_t>(offset + length);
  return true;
}

[[noreturn]] void fail(const char* what) {
  __builtin_printf("fuzz_params: property violated: %s\n", what);
  abort();
}

void check_valid(const fw::Params& p) {
  for (uint8_t i = 0; i < fw::kParamCount; ++i) {
    const fw::ParamInfo info = fw::param_info(i);
    const float v = p.get(i);
    if (!(v >= info.min && v <= info.max)) fail("a loaded parameter is outside its range or not finite");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > sizeof g_store) return 0;
  memcpy(g_store, data, size);
  g_size = static_cast<uint16_t>(size);
  const fw::StorageIo io{store_read, store_write};
  fw::Params params;
  const fw::StoreStatus status = fw::params_load(io, params);
  check_valid(params);
  if (status == fw::StoreStatus::kLoaded) {
    if (!fw::params_save_all(io, params)) fail("a loaded store cannot be saved again");
    fw::Params again;
    if (fw::params_load(io, again) != fw::StoreStatus::kLoaded) fail("a saved store does not load");
    for (uint8_t i = 0; i < fw::kParamCount; ++i)
      if (params.get(i) != again.get(i)) fail("values changed in a save/load");
  }
  return 0;
}
