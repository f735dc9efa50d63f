// One folder per run: log.csv (a row per control period, flushed as written), events.log (commands,
// acknowledgements, STATUSTEXT, faults), summary.json (rewritten atomically, `complete: false` until the
// run ends, so an interrupted run still leaves a readable summary that says it was cut short).
#pragma once

#include <cstdio>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace quad::sim {

// A small ordered JSON object builder (numbers, booleans, strings, nested objects, null).
class Json {
 public:
  Json& add(const std::string& key, double value);
  Json& add(const std::string& key, long value);
  Json& add(const std::string& key, int value) { return add(key, static_cast<long>(value)); }
  Json& add(const std::string& key, unsigned long value) { return add(key, static_cast<long>(value)); }
  Json& add(const std::string& key, bool value);
  Json& add(const std::string& key, const std::string& value);
  Json& add(const std::string& key, const char* value) { return add(key, std::string(value)); }
  Json& add(const std::string& key, const Json& object);
  Json& add_null(const std::string& key);
  std::string str(int indent = 0) const;

 private:
  std::vector<std::pair<std::string, std::string>> items_;  // key, encoded value (objects re-indented on output)
  std::vector<Json> objects_;
};

// Median, 95th percentile, maximum and count of a sample (an empty sample gives zeros).
Json percentiles_json(std::vector<double> sample);

class CsvLog {
 public:
  CsvLog(const std::string& path, const std::vector<std::string>& columns);
  ~CsvLog();
  CsvLog(const CsvLog&) = delete;
  CsvLog& operator=(const CsvLog&) = delete;
  // One row; values.size() must equal the column count. Flushed at once.
  void row(const std::vector<double>& values);

 private:
  std::FILE* f_ = nullptr;
  size_t columns_ = 0;
  std::string path_;
};

// Creates the folder (and parents). Throws with the path and reason on failure.
void make_directories(const std::string& path);
// Writes `text` to path via a temporary file and rename(), so readers never see half a file.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace quad::sim
