#include "sensor_log.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>

namespace quad::replay {

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(trim(cell));
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

struct Context {
  const std::string& name;
  int line;
};

[[noreturn]] void fail(const Context& c, const std::string& column, int index, const std::string& what) {
  std::ostringstream m;
  m << c.name << ":" << c.line << ": column '" << column << "' (" << index + 1 << "): " << what;
  throw LogError(m.str());
}

// The cell of `column` on this row as a finite number; nullopt when empty and `optional`.
std::optional<double> cell(const Context& c, const std::vector<std::string>& cells, const std::string& column,
                           int index, bool optional) {
  const std::string& text = index < static_cast<int>(cells.size()) ? cells[static_cast<size_t>(index)] : std::string();
  if (text.empty()) {
    if (optional) return std::nullopt;
    fail(c, column, index, "empty cell");
  }
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) {
    fail(c, column, index, "not a finite number: '" + text + "'");
  }
  return v;
}

}  // namespace

std::vector<LogRow> read_log(std::istream& in, const std::string& name) {
  std::string line;
  int line_no = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    header = split(t);
    break;
  }
  if (header.empty()) throw LogError(name + ": no header row");
  std::map<std::string, int> index;
  for (size_t i = 0; i < header.size(); ++i) index.emplace(header[i], static_cast<int>(i));
  const int header_line = line_no;
  auto column = [&](const std::string& col) {
    const auto it = index.find(col);
    if (it == index.end()) {
      throw LogError(name + ":" + std::to_string(header_line) + ": missing column '" + col + "' in the header");
    }
    return it->second;
  };
  const int i_t = column("t");
  const int i_g[3] = {column("gx"), column("gy"), column("gz")};
  const int i_a[3] = {column("ax"), column("ay"), column("az")};
  const int i_m[3] = {column("mx"), column("my"), column("mz")};
  const char* vis_names[4] = {"vis_t", "vis_x", "vis_y", "vis_z"};
  int present = 0;
  for (const char* v : vis_names) present += index.count(v) ? 1 : 0;
  if (present != 0 && present != 4) {
    for (const char* v : vis_names) column(v);  // names the first missing one
  }
  const bool has_vis = present == 4;
  const int i_v[4] = {has_vis ? index["vis_t"] : -1, has_vis ? index["vis_x"] : -1, has_vis ? index["vis_y"] : -1,
                      has_vis ? index["vis_z"] : -1};

  std::vector<LogRow> rows;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> cells = split(t);
    const Context c{name, line_no};
    LogRow r;
    r.line = line_no;
    r.t = *cell(c, cells, "t", i_t, false);
    if (!rows.empty() && r.t < rows.back().t) {
      std::ostringstream m;
      m << "time goes backwards (" << r.t << " s after " << rows.back().t << " s on line " << rows.back().line << ")";
      fail(c, "t", i_t, m.str());
    }
    for (int k = 0; k < 3; ++k) {
      r.gyro[k] = *cell(c, cells, header[static_cast<size_t>(i_g[k])], i_g[k], false);
      r.accel[k] = *cell(c, cells, header[static_cast<size_t>(i_a[k])], i_a[k], false);
    }
    std::optional<double> m[3];
    int mag_cells = 0;
    for (int k = 0; k < 3; ++k) {
      m[k] = cell(c, cells, header[static_cast<size_t>(i_m[k])], i_m[k], true);
      mag_cells += m[k] ? 1 : 0;
    }
    if (mag_cells == 3) {
      r.mag = std::array<double, 3>{*m[0], *m[1], *m[2]};
    } else if (mag_cells != 0) {
      for (int k = 0; k < 3; ++k) {
        if (!m[k]) fail(c, header[static_cast<size_t>(i_m[k])], i_m[k], "empty cell in a partly filled magnetometer sample");
      }
    }
    if (has_vis) {
      std::optional<double> v[4];
      int vis_cells = 0;
      for (int k = 0; k < 4; ++k) {
        v[k] = cell(c, cells, vis_names[k], i_v[k], true);
        vis_cells += v[k] ? 1 : 0;
      }
      if (vis_cells == 4) {
        if (*v[0] > r.t) {
          std::ostringstream msg;
          msg << "vision fix captured at " << *v[0] << " s, after the row's time " << r.t << " s";
          fail(c, "vis_t", i_v[0], msg.str());
        }
        LogRow::Fix f;
        f.t = *v[0];
        for (int k = 0; k < 3; ++k) f.p[k] = *v[k + 1];
        r.fix = f;
      } else if (vis_cells != 0) {
        for (int k = 0; k < 4; ++k) {
          if (!v[k]) fail(c, vis_names[k], i_v[k], "empty cell in a partly filled vision fix");
        }
      }
    }
    rows.push_back(r);
  }
  if (rows.empty()) throw LogError(name + ": no data rows after the header");
  return rows;
}

}  // namespace quad::replay
