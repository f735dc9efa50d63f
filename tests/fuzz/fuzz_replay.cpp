// Fuzz target: the replay tool's CSV sensor-log reader, and the estimators run over what it accepts.
// A malformed log is refused with a LogError naming the line; an accepted one replays without a crash.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "replay.h"
#include "sensor_log.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::vector<quad::replay::LogRow> rows;
  try {
    rows = quad::replay::read_log(in, "fuzz.csv");
  } catch (const quad::replay::LogError& e) {
    if (std::string(e.what()).find("fuzz.csv") == std::string::npos) {
      std::printf("fuzz_replay: error does not name the file: %s\n", e.what());
      std::abort();
    }
    return 0;
  }
  if (rows.size() > 2000) return 0;  // keep each execution short; the reader itself ran on all of it
  std::ostringstream out;
  quad::replay::replay(rows, quad::replay::ReplayOptions{}, out);
  return 0;
}
