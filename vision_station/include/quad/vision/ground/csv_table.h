// A small CSV table with a header row (no quoting), for the ground-camera image lists.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace quad::vision::ground {

struct CsvRow {
  int line = 0;  // 1-based line in the file
  std::map<std::string, std::string> fields;
};

struct CsvTable {
  std::string path;
  std::vector<std::string> columns;
  std::vector<CsvRow> rows;
  // The field, or an error naming the file, line and column when it is missing.
  const std::string& at(const CsvRow& row, const std::string& column) const;
  double number(const CsvRow& row, const std::string& column) const;
  // A path in the table, made relative to the table's folder.
  std::string file(const CsvRow& row, const std::string& column) const;
};

// Throws std::runtime_error naming the file (and line) when it cannot be read, lacks a required column or
// a row has a different number of fields than the header.
CsvTable read_csv(const std::string& path, const std::vector<std::string>& required_columns);

}  // namespace quad::vision::ground
