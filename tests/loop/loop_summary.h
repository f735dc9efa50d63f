// Reading a flight's run folder in the loop tests: a whole file, and a number of summary.json.
#pragma once

#include <cmath>
#include <fstream>
#include <initializer_list>
#include <regex>
#include <sstream>
#include <string>

namespace quad::sim {

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The number at a path of keys in summary.json: each key is searched after the previous one.
inline double json_number(const std::string& json, std::initializer_list<const char*> keys) {
  size_t at = 0;
  std::string last;
  for (const char* key : keys) {
    at = json.find(std::string("\"") + key + "\"", at);
    if (at == std::string::npos) return NAN;
    last = key;
  }
  std::smatch m;
  const std::string rest = json.substr(at);
  if (!std::regex_search(rest, m, std::regex("^\"" + last + "\": (-?[0-9.eE+-]+)"))) return NAN;
  return std::stod(m[1]);
}

}  // namespace quad::sim
