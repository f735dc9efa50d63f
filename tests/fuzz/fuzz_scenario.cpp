// Fuzz target: the YAML scenario loader. Any input either loads or is refused with a ScenarioError that
// names the file (and, where there is one, the line and key); no other exception, crash or hang.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "quad/sim/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const quad::sim::Scenario s = quad::sim::parse_scenario(text, "fuzz.yaml", "/nonexistent");
    (void)s;
  } catch (const quad::sim::ScenarioError& e) {
    if (std::string(e.what()).find("fuzz.yaml") == std::string::npos) {
      std::printf("fuzz_scenario: error does not name the file: %s\n", e.what());
      std::abort();
    }
  }
  return 0;
}
