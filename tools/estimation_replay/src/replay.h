// Running the estimation layer over a parsed sensor log and writing the estimates as CSV.
#pragma once

#include <ostream>
#include <vector>

#include "quad/estimation/estimation.h"
#include "sensor_log.h"

namespace quad::replay {

enum class AttitudeFilter { kConditioned, kUnconditioned, kMahony, kLinear };

struct ReplayOptions {
  AttitudeFilter filter = AttitudeFilter::kConditioned;
  est::ObserverParams observer;             // Conditioned / Unconditioned (innovation set from `filter`)
  est::MahonyParams mahony;
  est::LinearComplementaryParams linear;
  est::PositionFilterParams position;
  bool fuse_on_arrival = false;             // stamp fixes with the row time instead of vis_t (comparison)
};

struct ReplaySummary {
  int rows = 0;
  int fixes = 0;
  est::PositionFilterHealth position;
  est::ObserverHealth observer;  // zero for the baselines
};

// Output columns.
constexpr const char* kOutputHeader = "t,qw,qx,qy,qz,roll,pitch,yaw,bgx,bgy,bgz,px,py,pz,vx,vy,vz";

// One output row per log row. The attitude filter initialises on the first row with a magnetometer
// sample (attitude cells are empty before it); the position filter on the first vision fix (position
// and velocity cells are empty before it).
ReplaySummary replay(const std::vector<LogRow>& rows, const ReplayOptions& options, std::ostream& out);

}  // namespace quad::replay
