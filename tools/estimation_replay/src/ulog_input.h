// A flight log in the firmware's ULog (docs/logging.md) as the replay's input: the IMU, magnetometer and
// vision-fix topics as sensor-log rows for the estimation layer's filters, and the whole log for the
// firmware's own estimator (firmware_replay.h).
#pragma once

#include <string>
#include <vector>

#include "sensor_log.h"
#include "ulog_reader.h"

namespace quad::replay {

// True when the file starts with the ULog magic.
bool is_ulog(const std::string& path);

// One row per sensor_combined record: t = timestamp (s), gyro_rad, accelerometer_m_s2; the sensor_mag
// record of the same timestamp (the sample handed to the same iteration); each vision_fix with a finite
// position (captured at timestamp_sample) on the first row at or after its arrival. Throws LogError
// naming the file when a topic or field is missing.
std::vector<LogRow> rows_from_ulog(const ulog::File& log);

}  // namespace quad::replay
