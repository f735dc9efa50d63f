// Fuzz target: the stereo calibration file loader (OpenCV FileStorage YAML). Any file either loads into a
// usable calibration or is refused with a CalibrationFileError naming the file; never another exception
// (e.g. a raw cv::Exception), a crash or a hang.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "quad/vision/stereo_calibration.h"

namespace {
std::string scratch_path() {
  static const std::string path = "/tmp/fuzz_calibration_" + std::to_string(getpid()) + ".yaml";
  return path;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = scratch_path();
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  try {
    const quad::vision::StereoCalibration c = quad::vision::load_calibration(path);
    (void)c.baseline();
  } catch (const quad::vision::CalibrationFileError& e) {
    if (std::string(e.what()).find(path) == std::string::npos) {
      std::printf("fuzz_calibration: error does not name the file: %s\n", e.what());
      std::abort();
    }
  }
  return 0;
}
