#include "ulog_input.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>

namespace quad::replay {

bool is_ulog(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[7] = {};
  return in.read(magic, sizeof magic) && std::memcmp(magic, "ULog\x01\x12\x35", sizeof magic) == 0;
}

namespace {

const ulog::Layout& topic(const ulog::File& log, const char* name) {
  try {
    return log.layout(name);
  } catch (const ulog::Error& e) {
    throw LogError(e.what());
  }
}

const ulog::FieldRef& field(const ulog::File& log, const ulog::Layout& l, const char* name) {
  try {
    return l.field(name);
  } catch (const ulog::Error& e) {
    throw LogError(log.path() + ": " + e.what());
  }
}

}  // namespace

std::vector<LogRow> rows_from_ulog(const ulog::File& log) {
  const ulog::Layout& imu = topic(log, "sensor_combined");
  const ulog::FieldRef& gyro = field(log, imu, "gyro_rad");
  const ulog::FieldRef& accel = field(log, imu, "accelerometer_m_s2");
  const std::vector<uint16_t> imu_ids = log.ids_of("sensor_combined");
  // Magnetometer samples by timestamp: the writer may log one before or after its iteration's IMU record.
  std::map<uint64_t, std::array<double, 3>> mags;
  std::vector<uint16_t> mag_ids, fix_ids;
  const ulog::Layout* mag = nullptr;
  const ulog::Layout* fix = nullptr;
  if (!(mag_ids = log.ids_of("sensor_mag")).empty()) mag = &log.layout("sensor_mag");
  if (!(fix_ids = log.ids_of("vision_fix")).empty()) fix = &log.layout("vision_fix");
  const auto is = [](const std::vector<uint16_t>& ids, uint16_t id) {
    for (uint16_t i : ids) {
      if (i == id) return true;
    }
    return false;
  };
  for (const ulog::Record& r : log.records()) {
    if (mag == nullptr || r.kind != ulog::Record::Kind::kData || !is(mag_ids, r.msg_id)) continue;
    const ulog::FieldRef& m = field(log, *mag, "magnetometer_ga");
    mags[r.timestamp] = {ulog::number(r, m, 0), ulog::number(r, m, 1), ulog::number(r, m, 2)};
  }

  std::vector<LogRow> rows;
  std::vector<LogRow::Fix> waiting;  // fixes that arrived since the last IMU row
  for (const ulog::Record& r : log.records()) {
    if (r.kind != ulog::Record::Kind::kData) continue;
    if (fix != nullptr && is(fix_ids, r.msg_id)) {
      LogRow::Fix f;
      f.t = ulog::number(r, field(log, *fix, "timestamp_sample")) * 1e-6;
      const char* axes[3] = {"x", "y", "z"};
      bool finite = true;
      for (int i = 0; i < 3; ++i) {
        f.p[i] = ulog::number(r, field(log, *fix, axes[i]));
        finite = finite && std::isfinite(f.p[i]);
      }
      if (finite) waiting.push_back(f);
      continue;
    }
    if (!is(imu_ids, r.msg_id)) continue;
    LogRow row;
    row.line = static_cast<int>(rows.size()) + 1;
    row.t = static_cast<double>(r.timestamp) * 1e-6;
    for (int i = 0; i < 3; ++i) {
      row.gyro[i] = ulog::number(r, gyro, i);
      row.accel[i] = ulog::number(r, accel, i);
    }
    const auto m = mags.find(r.timestamp);
    if (m != mags.end()) row.mag = m->second;
    // The sensor-log row carries one fix; more between two samples (rare) go on the following rows.
    if (!waiting.empty() && waiting.front().t <= row.t) {
      row.fix = waiting.front();
      waiting.erase(waiting.begin());
    }
    rows.push_back(row);
  }
  if (rows.empty()) throw LogError(log.path() + ": no sensor_combined records");
  return rows;
}

}  // namespace quad::replay
