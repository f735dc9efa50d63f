#include "log_dir.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace quad::fw {

namespace fs = std::filesystem;

namespace {

// NNN of "log_NNN.ulg" (at least three digits), or false.
bool log_number(const std::string& name, unsigned* number) {
  const std::string prefix = "log_", suffix = ".ulg";
  if (name.size() < prefix.size() + 3 + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return false;
  *number = static_cast<unsigned>(std::stoul(digits));
  return true;
}

std::string file_name(unsigned number) {
  char name[32];
  std::snprintf(name, sizeof name, "log_%03u.ulg", number);
  return name;
}

}  // namespace

LogDirectory::LogDirectory() : write_buffer_(64 * 1024) {
  store_.context = this;
  store_.open = [](void* c, uint32_t t) { return static_cast<LogDirectory*>(c)->open_log(t); };
  store_.append = [](void* c, const uint8_t* d, uint16_t n) { return static_cast<LogDirectory*>(c)->append(d, n); };
  store_.close = [](void* c) { static_cast<LogDirectory*>(c)->close_log(); };
  store_.count = [](void* c) { return static_cast<LogDirectory*>(c)->count(); };
  store_.entry = [](void* c, uint16_t id, LogEntry* e) { return static_cast<LogDirectory*>(c)->entry(id, e); };
  store_.read = [](void* c, uint16_t id, uint32_t offset, uint8_t* dst, uint16_t n) {
    return static_cast<LogDirectory*>(c)->read(id, offset, dst, n);
  };
  store_.erase_all = [](void* c) { return static_cast<LogDirectory*>(c)->erase_all(); };
}

LogDirectory::~LogDirectory() {
  close_log();
  if (reading_ != nullptr) std::fclose(reading_);
}

bool LogDirectory::attach(const std::string& dir, std::string* error) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) {
    *error = "--log-dir " + dir + ": not a directory" + (ec ? " (" + ec.message() + ")" : std::string());
    return false;
  }
  dir_ = dir;
  logs_.clear();
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    unsigned number = 0;
    if (e.is_regular_file() && log_number(e.path().filename().string(), &number)) logs_.push_back(Log{number, 0});
  }
  if (ec) {
    *error = "--log-dir " + dir + ": " + ec.message();
    return false;
  }
  std::sort(logs_.begin(), logs_.end(), [](const Log& a, const Log& b) { return a.number < b.number; });
  if (logs_.size() > 0xFFFFu - 1) {
    *error = "--log-dir " + dir + ": more logs than MAVLink can number";
    return false;
  }
  return true;
}

std::string LogDirectory::path(uint16_t id) const {
  if (id == 0 || id > logs_.size()) return "";
  return dir_ + "/" + file_name(logs_[id - 1].number);
}

bool LogDirectory::open_log(uint32_t time_utc_s) {
  close_log();
  if (dir_.empty() || logs_.size() >= 0xFFFFu - 1) return false;
  const unsigned number = logs_.empty() ? 1u : logs_.back().number + 1u;
  const std::string file = dir_ + "/" + file_name(number);
  writing_ = std::fopen(file.c_str(), "wbx");  // never over an existing file
  if (writing_ == nullptr) {
    std::fprintf(stderr, "quad_firmware: %s: %s\n", file.c_str(), std::strerror(errno));
    return false;
  }
  std::setvbuf(writing_, write_buffer_.data(), _IOFBF, write_buffer_.size());
  logs_.push_back(Log{number, time_utc_s});
  return true;
}

uint16_t LogDirectory::append(const uint8_t* data, uint16_t length) {
  if (writing_ == nullptr) return 0;
  return static_cast<uint16_t>(std::fwrite(data, 1, length, writing_));
}

void LogDirectory::close_log() {
  if (writing_ == nullptr) return;
  std::fclose(writing_);
  writing_ = nullptr;
}

bool LogDirectory::entry(uint16_t id, LogEntry* out) {
  const std::string file = path(id);
  if (file.empty()) return false;
  if (writing_ != nullptr && id == logs_.size()) std::fflush(writing_);
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) return false;
  out->size_bytes = static_cast<uint32_t>(std::min<std::uintmax_t>(size, 0xFFFFFFFFu));
  out->time_utc_s = logs_[id - 1].time_utc_s;
  return true;
}

uint16_t LogDirectory::read(uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length) {
  const std::string file = path(id);
  if (file.empty()) return 0;
  if (writing_ != nullptr && id == logs_.size()) std::fflush(writing_);
  if (reading_ == nullptr || reading_id_ != id) {
    if (reading_ != nullptr) std::fclose(reading_);
    reading_ = std::fopen(file.c_str(), "rb");
    reading_id_ = id;
    if (reading_ == nullptr) return 0;
  }
  if (std::fseek(reading_, static_cast<long>(offset), SEEK_SET) != 0) return 0;
  std::clearerr(reading_);
  return static_cast<uint16_t>(std::fread(dst, 1, length, reading_));
}

bool LogDirectory::erase_all() {
  if (writing_ != nullptr) return false;
  if (reading_ != nullptr) std::fclose(reading_);
  reading_ = nullptr;
  reading_id_ = 0;
  bool ok = true;
  for (uint16_t id = 1; id <= logs_.size(); ++id) {
    std::error_code ec;
    ok = fs::remove(path(id), ec) && ok;
  }
  logs_.clear();
  return ok;
}

}  // namespace quad::fw
