// The error figures of a replay against the truth of a simulated flight: the run folder's log.csv
// (columns t, true_n, true_e, true_d, true_roll, true_pitch, true_yaw; others ignored).
#pragma once

#include <string>
#include <vector>

#include "replay.h"

namespace quad::replay {

struct TruthRow {
  double t = 0.0;
  double p[3] = {0, 0, 0};
  double roll = 0.0, pitch = 0.0, yaw = 0.0;
};

// Throws LogError naming the file, line and column on a missing column or a bad cell.
std::vector<TruthRow> read_truth(const std::string& path);

struct ErrorFigures {
  int attitude_rows = 0, position_rows = 0;
  double tilt_rms_deg = 0.0;        // angle between the estimated and the true down
  double yaw_rms_deg = 0.0;         // heading difference, wrapped
  double horizontal_rms_m = 0.0;    // |(n, e) - truth|
  double vertical_rms_m = 0.0;
};

// Over the estimates with from <= t <= to that are valid, each against the truth row at or before t.
ErrorFigures error_figures(const std::vector<Estimate>& track, const std::vector<TruthRow>& truth, double from,
                           double to);

}  // namespace quad::replay
