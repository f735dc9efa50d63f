// param_image: the parameter storage of a firmware image as a file, with the values of a parameter file
// (quad_sim's --params) stored the way the firmware stores them (fw::params_save_all, through
// fw::build_param_storage, which avr_pil uses for the AVR's EEPROM too). qemu_pil loads it into the
// Cortex-M image's RAM-backed storage, so an emulated processor runs with the same parameters as
// quad_firmware on the host.
//
//   param_image --size BYTES --out BLOB [--params FILE]
//
// Without --params the blob is erased storage (0xFF), which the firmware reads as "first boot: defaults".
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "param_file.h"

namespace {

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
  std::vector<uint8_t> storage(static_cast<size_t>(size), 0xFF);
  if (!params_path.empty()) {
    std::string error;
    if (!quad::fw::build_param_storage(params_path, storage.size(), &storage, &error)) {
      std::fprintf(stderr, "param_image: %s\n", error.c_str());
      return 1;
    }
  }
  std::ofstream out(out_path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(storage.data()), static_cast<std::streamsize>(storage.size()));
  if (!out) {
    std::fprintf(stderr, "param_image: cannot write %s\n", out_path.c_str());
    return 1;
  }
  return 0;
}
