// For the flight-log tests: a LogStore in RAM that can play a busy device, and the field's reader
// (tools/node/ulog_check.js, @foxglove/ulog) run on what it holds.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <regex>
#include <string>
#include <vector>

#include "quad/firmware/log_store.h"

namespace quad::fw::test {

class RamLogStore {
 public:
  RamLogStore() {
    store_.context = this;
    store_.open = [](void* c, uint32_t) {
      auto* s = static_cast<RamLogStore*>(c);
      s->logs.emplace_back();
      s->open_ = true;
      return true;
    };
    store_.append = [](void* c, const uint8_t* d, uint16_t n) { return static_cast<RamLogStore*>(c)->append(d, n); };
    store_.close = [](void* c) { static_cast<RamLogStore*>(c)->open_ = false; };
    store_.count = [](void* c) { return static_cast<uint16_t>(static_cast<RamLogStore*>(c)->logs.size()); };
    store_.entry = nullptr;
    store_.read = nullptr;
    store_.erase_all = nullptr;
  }
  const LogStore* store() const { return &store_; }
  bool open() const { return open_; }

  // Busy pattern: every call takes at most max_take bytes, and of every busy_every calls (0: none) the
  // first busy_run take nothing.
  uint16_t max_take = 0xFFFF;
  unsigned busy_every = 0;
  unsigned busy_run = 1;
  std::vector<std::vector<uint8_t>> logs;

 private:
  uint16_t append(const uint8_t* d, uint16_t n) {
    if (!open_) return 0;
    ++calls_;
    if (busy_every != 0 && calls_ % busy_every < busy_run) return 0;
    const uint16_t take = n < max_take ? n : max_take;
    logs.back().insert(logs.back().end(), d, d + take);
    return take;
  }
  LogStore store_;
  bool open_ = false;
  unsigned long calls_ = 0;
};

struct ReaderResult {
  int status = -1;
  std::string out;
  std::string err;
};

// Writes bytes to a scratch file and reads it with ulog_check.js (extra: its options).
inline ReaderResult read_with_node(const std::vector<uint8_t>& bytes, const std::string& name,
                                   const std::string& extra = "") {
  const std::string node = QUAD_NODE_EXECUTABLE;
  EXPECT_FALSE(node.empty() || node.find("NOTFOUND") != std::string::npos)
      << "node was not found when CMake configured the build; install it with `make setup`";
  const std::string dir = ::testing::TempDir();
  const std::string file = dir + "/" + name + ".ulg";
  std::FILE* f = std::fopen(file.c_str(), "wb");
  EXPECT_NE(f, nullptr) << file;
  if (f == nullptr) return {};
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  const std::string err = dir + "/" + name + ".stderr";
  const std::string cmd = node + " " + QUAD_NODE_DIR + "/ulog_check.js " + file + " " + extra + " 2>" + err;
  ReaderResult r;
  std::FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while (p != nullptr && (n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = p != nullptr ? pclose(p) : -1;
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (std::FILE* e = std::fopen(err.c_str(), "r")) {
    while ((n = std::fread(buf, 1, sizeof buf, e)) > 0) r.err.append(buf, n);
    std::fclose(e);
  }
  return r;
}

// The number after `"key": ` within the JSON object of topic `topic` (the reader's output), from its
// `section` ("first", "last") when given; -1 when absent.
inline long topic_number(const std::string& json, const std::string& topic, const std::string& key,
                         const std::string& section = "") {
  const size_t at = json.find("\"topics\"");
  size_t t = json.find("\"" + topic + "\": {", at == std::string::npos ? 0 : at);
  if (t == std::string::npos) return -1;
  if (!section.empty() && (t = json.find("\"" + section + "\": {", t)) == std::string::npos) return -1;
  std::smatch m;
  const std::string rest = json.substr(t);
  if (!std::regex_search(rest, m, std::regex("\"" + key + "\": (-?[0-9]+)"))) return -1;
  return std::stol(m[1]);
}

}  // namespace quad::fw::test
