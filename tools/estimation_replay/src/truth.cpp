#include "truth.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace quad::replay {

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  return cells;
}

// The rotation of ZYX Euler angles, as a unit quaternion in double.
void euler_to_quat(double roll, double pitch, double yaw, double q[4]) {
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2), cp = std::cos(pitch / 2), sp = std::sin(pitch / 2);
  const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  q[0] = cr * cp * cy + sr * sp * sy;
  q[1] = sr * cp * cy - cr * sp * sy;
  q[2] = cr * sp * cy + sr * cp * sy;
  q[3] = cr * cp * sy - sr * sp * cy;
}

// The third row of R_IB (the body's view of NED down) from q_IB.
void down_in_body(const double q[4], double d[3]) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  d[0] = 2 * (x * z - w * y);
  d[1] = 2 * (y * z + w * x);
  d[2] = w * w - x * x - y * y + z * z;
}

}  // namespace

std::vector<TruthRow> read_truth(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw LogError(path + ": cannot open");
  std::string line;
  if (!std::getline(in, line)) throw LogError(path + ":1: no header row");
  const std::vector<std::string> header = split(line);
  const char* names[7] = {"t", "true_n", "true_e", "true_d", "true_roll", "true_pitch", "true_yaw"};
  int column[7];
  for (int i = 0; i < 7; ++i) {
    const auto it = std::find(header.begin(), header.end(), names[i]);
    if (it == header.end()) throw LogError(path + ":1: column '" + names[i] + "' missing");
    column[i] = static_cast<int>(it - header.begin());
  }
  std::vector<TruthRow> rows;
  for (int number = 2; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    const std::vector<std::string> cells = split(line);
    double v[7];
    for (int i = 0; i < 7; ++i) {
      const std::string cell = column[i] < static_cast<int>(cells.size()) ? cells[column[i]] : "";
      char* end = nullptr;
      v[i] = std::strtod(cell.c_str(), &end);
      if (cell.empty() || *end != '\0' || !std::isfinite(v[i])) {
        throw LogError(path + ":" + std::to_string(number) + ": column '" + names[i] + "': not a number: '" + cell + "'");
      }
    }
    if (!rows.empty() && v[0] < rows.back().t) {
      throw LogError(path + ":" + std::to_string(number) + ": column 't': time goes backwards");
    }
    rows.push_back(TruthRow{v[0], {v[1], v[2], v[3]}, v[4], v[5], v[6]});
  }
  if (rows.empty()) throw LogError(path + ": no rows");
  return rows;
}

ErrorFigures error_figures(const std::vector<Estimate>& track, const std::vector<TruthRow>& truth, double from,
                           double to) {
  ErrorFigures f;
  double tilt2 = 0, yaw2 = 0, h2 = 0, v2 = 0;
  for (const Estimate& e : track) {
    if (e.t < from || e.t > to) continue;
    auto it = std::upper_bound(truth.begin(), truth.end(), e.t, [](double t, const TruthRow& r) { return t < r.t; });
    if (it == truth.begin()) continue;
    const TruthRow& r = *(it - 1);
    if (e.attitude_valid) {
      double qt[4], dt[3], de[3];
      euler_to_quat(r.roll, r.pitch, r.yaw, qt);
      const double qe[4] = {e.q.w, e.q.x, e.q.y, e.q.z};
      down_in_body(qt, dt);
      down_in_body(qe, de);
      const double c = dt[0] * de[0] + dt[1] * de[1] + dt[2] * de[2];
      const double s = std::sqrt(std::pow(dt[1] * de[2] - dt[2] * de[1], 2) + std::pow(dt[2] * de[0] - dt[0] * de[2], 2) +
                                 std::pow(dt[0] * de[1] - dt[1] * de[0], 2));
      const double tilt = std::atan2(s, c);
      const double yaw_e = std::atan2(2 * (qe[0] * qe[3] + qe[1] * qe[2]), 1 - 2 * (qe[2] * qe[2] + qe[3] * qe[3]));
      const double dyaw = std::remainder(yaw_e - r.yaw, 2 * M_PI);
      tilt2 += tilt * tilt;
      yaw2 += dyaw * dyaw;
      ++f.attitude_rows;
    }
    if (e.position_valid) {
      const double dn = e.p.x - r.p[0], de_ = e.p.y - r.p[1], dd = e.p.z - r.p[2];
      h2 += dn * dn + de_ * de_;
      v2 += dd * dd;
      ++f.position_rows;
    }
  }
  const double deg = 180.0 / M_PI;
  if (f.attitude_rows > 0) {
    f.tilt_rms_deg = deg * std::sqrt(tilt2 / f.attitude_rows);
    f.yaw_rms_deg = deg * std::sqrt(yaw2 / f.attitude_rows);
  }
  if (f.position_rows > 0) {
    f.horizontal_rms_m = std::sqrt(h2 / f.position_rows);
    f.vertical_rms_m = std::sqrt(v2 / f.position_rows);
  }
  return f;
}

}  // namespace quad::replay
