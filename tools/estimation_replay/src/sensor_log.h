// Reading the replay tool's CSV sensor log.
//
// Header row with column names; required columns t gx gy gz ax ay az mx my mz, optional vis_t vis_x
// vis_y vis_z (all four or none); other columns are ignored. Units: t and vis_t in seconds, gyro rad/s
// FRD, accelerometer m/s^2 specific force FRD, magnetometer any unit FRD, vision NED metres. Empty cells
// are allowed for the vision fix (no fix on that row) and for the magnetometer (no new sample on that
// row, all three empty). Blank lines and lines starting with '#' are skipped.
#pragma once

#include <array>
#include <istream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace quad::replay {

struct LogRow {
  int line = 0;  // 1-based line in the file
  double t = 0.0;
  double gyro[3] = {0, 0, 0};
  double accel[3] = {0, 0, 0};
  std::optional<std::array<double, 3>> mag;
  struct Fix {
    double t = 0.0;
    double p[3] = {0, 0, 0};
  };
  std::optional<Fix> fix;
};

// A malformed log: the message names the file, line and column.
class LogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses the whole log; throws LogError on a missing column, a non-numeric or non-finite cell, a
// partially filled group, a fix captured after the row that delivers it, or time going backwards.
std::vector<LogRow> read_log(std::istream& in, const std::string& name);

}  // namespace quad::replay
