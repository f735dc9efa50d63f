#include "quad/vision/ground/csv_table.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace quad::vision::ground {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream stream(line);
  std::string field;
  while (std::getline(stream, field, ',')) {
    field.erase(0, field.find_first_not_of(" \t\r"));
    field.erase(field.find_last_not_of(" \t\r") + 1);
    out.push_back(field);
  }
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

}  // namespace

const std::string& CsvTable::at(const CsvRow& row, const std::string& column) const {
  const auto it = row.fields.find(column);
  if (it == row.fields.end()) {
    throw std::runtime_error(path + ":" + std::to_string(row.line) + ": no column '" + column + "'");
  }
  return it->second;
}

double CsvTable::number(const CsvRow& row, const std::string& column) const {
  const std::string& text = at(row, column);
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(path + ":" + std::to_string(row.line) + ": column '" + column + "' is not a number: '" +
                           text + "'");
}

std::string CsvTable::file(const CsvRow& row, const std::string& column) const {
  const std::string& name = at(row, column);
  if (name.empty()) throw std::runtime_error(path + ":" + std::to_string(row.line) + ": column '" + column + "' is empty");
  if (name[0] == '/') return name;
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? name : path.substr(0, slash + 1) + name;
}

CsvTable read_csv(const std::string& path, const std::vector<std::string>& required) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  CsvTable table;
  table.path = path;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    const std::vector<std::string> fields = split(line);
    if (table.columns.empty()) {
      table.columns = fields;
      for (const std::string& column : required) {
        if (std::find(fields.begin(), fields.end(), column) == fields.end()) {
          throw std::runtime_error(path + ":" + std::to_string(number) + ": header lacks the column '" + column + "'");
        }
      }
      continue;
    }
    if (fields.size() != table.columns.size()) {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": " + std::to_string(fields.size()) +
                               " fields, the header has " + std::to_string(table.columns.size()));
    }
    CsvRow row;
    row.line = number;
    for (size_t i = 0; i < fields.size(); ++i) row.fields[table.columns[i]] = fields[i];
    table.rows.push_back(row);
  }
  if (table.columns.empty()) throw std::runtime_error(path + ": empty (no header)");
  return table;
}

}  // namespace quad::vision::ground
