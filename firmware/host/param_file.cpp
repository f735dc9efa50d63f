#include "param_file.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "quad/firmware/params.h"

namespace quad {
namespace fw {
namespace {

std::string format_float(float v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool parse_float(const std::string& token, float* out) {
  if (token.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (errno != 0 || end == nullptr || *end != '\0' || !std::isfinite(v)) return false;
  *out = static_cast<float>(v);
  return true;
}

}  // namespace

bool parse_param_text(const std::string& text, const std::string& origin, std::vector<ParamOverride>* out,
                      std::string* error) {
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const std::string where = origin + ":" + std::to_string(number) + ": ";
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string t; fields >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    std::string name, value;
    if (tokens.size() == 2) {
      name = tokens[0];
      value = tokens[1];
    } else if (tokens.size() == 5) {  // QGroundControl: system, component, name, value, type
      name = tokens[2];
      value = tokens[3];
    } else {
      *error = where + "expected 'NAME VALUE', found " + std::to_string(tokens.size()) + " fields";
      return false;
    }
    if (name.size() > kParamNameLength) {
      *error = where + "parameter name '" + name + "' is longer than 16 characters";
      return false;
    }
    const int16_t index = param_find(name.c_str());
    if (index < 0) {
      *error = where + "unknown parameter '" + name + "'";
      return false;
    }
    float v;
    if (!parse_float(value, &v)) {
      *error = where + name + ": value '" + value + "' is not a finite number";
      return false;
    }
    const ParamInfo info = param_info(static_cast<uint8_t>(index));
    if (v < info.min || v > info.max) {
      *error = where + name + ": " + value + " is outside [" + format_float(info.min) + ", " +
               format_float(info.max) + "]";
      return false;
    }
    out->push_back(ParamOverride{static_cast<uint8_t>(index), v});
  }
  return true;
}

bool read_param_file(const std::string& path, std::vector<ParamOverride>* out, std::string* error) {
  std::ifstream file(path);
  if (!file) {
    *error = "cannot open parameter file '" + path + "': " + std::strerror(errno);
    return false;
  }
  std::stringstream text;
  text << file.rdbuf();
  return parse_param_text(text.str(), path, out, error);
}

namespace {

// params_save_all() writes through plain function pointers: the buffer being built.
std::vector<uint8_t>* g_blob = nullptr;

bool blob_read(uint16_t offset, void* dst, uint16_t length) {
  if (static_cast<size_t>(offset) + length > g_blob->size()) return false;
  std::memcpy(dst, g_blob->data() + offset, length);
  return true;
}

bool blob_write(uint16_t offset, const void* src, uint16_t length) {
  if (static_cast<size_t>(offset) + length > g_blob->size()) return false;
  std::memcpy(g_blob->data() + offset, src, length);
  return true;
}

}  // namespace

bool build_param_storage(const std::string& path, size_t size, std::vector<uint8_t>* blob, std::string* error) {
  std::vector<ParamOverride> overrides;
  if (!read_param_file(path, &overrides, error)) return false;
  Params params;
  for (const ParamOverride& o : overrides) {
    if (params.set(o.index, o.value) != ParamError::kNone) {
      *error = path + ": " + param_info(o.index).name + " = " + format_float(o.value) + " refused";
      return false;
    }
  }
  // StorageIo offsets are 16 bits: a larger buffer could not be addressed as the firmware does.
  if (size > 65535) {
    *error = "a parameter storage of " + std::to_string(size) + " bytes is larger than 65535";
    return false;
  }
  std::vector<uint8_t> storage(size, 0xFF);
  g_blob = &storage;
  const bool saved = params_save_all(StorageIo{blob_read, blob_write}, params);
  g_blob = nullptr;
  if (!saved) {
    *error = "the parameters do not fit in " + std::to_string(size) + " bytes";
    return false;
  }
  blob->swap(storage);
  return true;
}

}  // namespace fw
}  // namespace quad
