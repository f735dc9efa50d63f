// param_image: the parameter storage of a firmware image as a file, with the values of a parameter file
// (quad_sim's --params) stored the way the firmware stores them (fw::params_save_all). qemu_pil loads it
// into the Cortex-M image's RAM-backed storage, so an emulated processor runs with the same parameters
// as quad_firmware on the host.
//
//   param_image --size BYTES --out BLOB [--params FILE]
//
// Without --params the blob is erased storage (0xFF), which the firmware reads as "first boot: defaults".
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "param_file.h"
#include "quad/firmware/params.h"

namespace {

std::vector<uint8_t> g_storage;

bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  if (static_cast<size_t>(offset) + length > g_storage.size()) return false;
  std::memcpy(dst, g_storage.data() + offset, length);
  return true;
}

bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  if (static_cast<size_t>(offset) + length > g_storage.size()) return false;
  std::memcpy(g_storage.data() + offset, src, length);
  return true;
}

int usage() {
  std::fprintf(stderr, "usage: param_image --size BYTES --out BLOB [--params FILE]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string params_path, out_path;
  long size = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--params") params_path = argv[i + 1];
    else if (flag == "--out") out_path = argv[i + 1];
    else if (flag == "--size") size = std::strtol(argv[i + 1], nullptr, 10);
    else return usage();
  }
  if (argc % 2 != 1 || out_path.empty() || size <= 0 || size > 65535) return usage();
  g_storage.assign(static_cast<size_t>(size), 0xFF);
  if (!params_path.empty()) {
    std::vector<quad::fw::ParamOverride> overrides;
    std::string error;
    if (!quad::fw::read_param_file(params_path, &overrides, &error)) {
      std::fprintf(stderr, "param_image: %s\n", error.c_str());
      return 1;
    }
    quad::fw::Params params;
    for (const quad::fw::ParamOverride& o : overrides) {
      if (params.set(o.index, o.value) != quad::fw::ParamError::kNone) {
        std::fprintf(stderr, "param_image: %s: %s = %g refused\n", params_path.c_str(),
                     quad::fw::param_info(o.index).name, static_cast<double>(o.value));
        return 1;
      }
    }
    if (!quad::fw::params_save_all(quad::fw::StorageIo{storage_read, storage_write}, params)) {
      std::fprintf(stderr, "param_image: the parameters do not fit in %ld bytes\n", size);
      return 1;
    }
  }
  std::ofstream out(out_path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(g_storage.data()), static_cast<std::streamsize>(g_storage.size()));
  if (!out) {
    std::fprintf(stderr, "param_image: cannot write %s\n", out_path.c_str());
    return 1;
  }
  return 0;
}
