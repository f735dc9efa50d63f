// The host's --params file: parameter values for one run, one "NAME VALUE" pair per line.
//
//   # comment (also after a value)
//   SYS_LOOP_HZ 400
//   FS_RC_ENABLE 0
//
// QGroundControl's parameter export ("SYS COMP NAME VALUE TYPE", tab-separated) is read as well.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include <string>
#include <vector>

namespace quad {
namespace fw {

struct ParamOverride {
  uint8_t index;
  float value;
};

// Reads and checks the whole file (names, numbers, ranges). On failure returns false with a message
// naming the file, the line and the field in *error.
bool read_param_file(const std::string& path, std::vector<ParamOverride>* out, std::string* error);

// The same for text already in memory; `origin` names it in messages.
bool parse_param_text(const std::string& text, const std::string& origin, std::vector<ParamOverride>* out,
                      std::string* error);

// The parameter storage of a board whose storage is `size` bytes (0xFF, erased), after the firmware
// saved the defaults with the values of the file at `path` applied (fw::params_save_all, the firmware's
// own store format and offset). An emulated board preloaded with it boots with those parameters. On
// failure returns false with a message naming the file (and the parameter) in *error.
bool build_param_storage(const std::string& path, size_t size, std::vector<uint8_t>* blob, std::string* error);

}  // namespace fw
}  // namespace quad
