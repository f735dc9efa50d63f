#include "quad/sim/run_output.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <sys/stat.h>

namespace quad::sim {
namespace {

std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

}  // namespace

Json percentiles_json(std::vector<double> v) {
  Json j;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v.empty() ? 0.0 : v[static_cast<size_t>(std::lround(q * (v.size() - 1)))]; };
  j.add("median", at(0.5)).add("p95", at(0.95)).add("max", at(1.0)).add("count", static_cast<long>(v.size()));
  return j;
}

Json& Json::add(const std::string& key, double value) {
  if (!std::isfinite(value)) return add_null(key);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", value);
  items_.emplace_back(key, buf);
  return *this;
}
Json& Json::add(const std::string& key, long value) {
  items_.emplace_back(key, std::to_string(value));
  return *this;
}
Json& Json::add(const std::string& key, bool value) {
  items_.emplace_back(key, value ? "true" : "false");
  return *this;
}
Json& Json::add(const std::string& key, const std::string& value) {
  items_.emplace_back(key, quote(value));
  return *this;
}
Json& Json::add_null(const std::string& key) {
  items_.emplace_back(key, "null");
  return *this;
}
Json& Json::add(const std::string& key, const Json& object) {
  objects_.push_back(object);
  items_.emplace_back(key, "\x01" + std::to_string(objects_.size() - 1));  // placeholder, expanded in str()
  return *this;
}

std::string Json::str(int indent) const {
  const std::string pad(static_cast<size_t>(indent + 2), ' ');
  std::string out = "{\n";
  for (size_t i = 0; i < items_.size(); ++i) {
    const auto& [key, value] = items_[i];
    out += pad + quote(key) + ": ";
    out += value[0] == '\x01' ? objects_[std::stoul(value.substr(1))].str(indent + 2) : value;
    out += i + 1 < items_.size() ? ",\n" : "\n";
  }
  return out + std::string(static_cast<size_t>(indent), ' ') + "}";
}

CsvLog::CsvLog(const std::string& path, const std::vector<std::string>& columns) : columns_(columns.size()), path_(path) {
  f_ = std::fopen(path.c_str(), "w");
  if (!f_) throw std::runtime_error(path + ": " + std::strerror(errno));
  for (size_t i = 0; i < columns.size(); ++i) std::fprintf(f_, "%s%s", i ? "," : "", columns[i].c_str());
  std::fputc('\n', f_);
  std::fflush(f_);
}

CsvLog::~CsvLog() {
  if (f_) std::fclose(f_);
}

void CsvLog::row(const std::vector<double>& values) {
  if (values.size() != columns_)
    throw std::logic_error(path_ + ": row of " + std::to_string(values.size()) + " values for " + std::to_string(columns_) + " columns");
  for (size_t i = 0; i < values.size(); ++i) std::fprintf(f_, "%s%.9g", i ? "," : "", values[i]);
  std::fputc('\n', f_);
  std::fflush(f_);  // a run cut short still has every row written so far
}

void make_directories(const std::string& path) {
  std::string partial;
  std::stringstream ss(path);
  std::string part;
  if (!path.empty() && path[0] == '/') partial = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST)
      throw std::runtime_error(partial + ": cannot create the folder: " + std::strerror(errno));
  }
}

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f) throw std::runtime_error(tmp + ": " + std::strerror(errno));
  std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw std::runtime_error(path + ": " + std::strerror(errno));
}

}  // namespace quad::sim
