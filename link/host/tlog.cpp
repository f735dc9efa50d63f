#include "quad/link/tlog.h"

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <sys/time.h>

namespace quad::tlog {

uint64_t unix_micros_now() {
  timeval tv;
  gettimeofday(&tv, nullptr);
  return static_cast<uint64_t>(tv.tv_sec) * 1000000u + static_cast<uint64_t>(tv.tv_usec);
}

TlogWriter::TlogWriter(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw std::runtime_error(path + ": cannot create: " + std::strerror(errno));
}

TlogWriter::~TlogWriter() {
  if (file_) std::fclose(file_);
}

void TlogWriter::write(uint64_t unix_us, const uint8_t* frame, size_t size) {
  if (unix_us < last_us_) unix_us = last_us_;
  uint8_t stamp[8];
  for (int i = 0; i < 8; ++i) stamp[i] = static_cast<uint8_t>(unix_us >> (56 - 8 * i));  // big-endian
  if (std::fwrite(stamp, 1, sizeof stamp, file_) != sizeof stamp || std::fwrite(frame, 1, size, file_) != size)
    throw std::runtime_error(path_ + ": write failed: " + std::strerror(errno));
  last_us_ = unix_us;
  ++records_;
  // A run cut short (a killed simulator, a crashed tool) keeps all but its last second.
  if (unix_us - flushed_us_ >= 1000000u) flush();
}

void TlogWriter::flush() {
  std::fflush(file_);
  flushed_us_ = last_us_;
}

void TlogStream::feed(const uint8_t* data, size_t size, uint64_t unix_us) {
  parser_.feed(data, size, [&](const mavlink::Frame& f) { writer_.write(unix_us, f.bytes, f.size); });
}

}  // namespace quad::tlog
