// Running the estimation layer over a parsed sensor log and writing the estimates as CSV.
#pragma once

#include <ostream>
#include <vector>

#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/estimation.h"
#include "sensor_log.h"

namespace quad::replay {

// kEkf: the error-state EKF of seed 004 (quad/estimation/delayed_ekf.h) in place of both the attitude
// filter and the position filter (its attitude starts from the conditioned observer's initialisation).
enum class AttitudeFilter { kConditioned, kUnconditioned, kMahony, kLinear, kEkf };

struct ReplayOptions {
  AttitudeFilter filter = AttitudeFilter::kConditioned;
  est::ObserverParams observer;             // Conditioned / Unconditioned (innovation set from `filter`)
  est::MahonyParams mahony;
  est::LinearComplementaryParams linear;
  est::PositionFilterParams position;
  bool fuse_on_arrival = false;             // stamp fixes with the row time instead of vis_t (comparison)
  // The EKF takes the star as seen from the body: a logged fix's NED position p is turned back into
  // R^T (star - p) with the EKF's own attitude at its capture time, so the update sees the position
  // alone (a log holds no star attitude to replay).
  Vec3 star_ned;                            // VIS_STAR_N/E/D (a ULog's parameters, else --star)
  est::EkfParams ekf;
};

// One row's estimate, for the error figures (valid flags: the filter had initialised).
struct Estimate {
  double t = 0.0;
  bool attitude_valid = false, position_valid = false;
  Quat q;
  Vec3 p;
};

struct ReplaySummary {
  int rows = 0;
  int fixes = 0;
  est::PositionFilterHealth position;
  est::ObserverHealth observer;  // zero for the baselines
  est::DelayedEkfHealth ekf;     // zero but for the EKF
};

// Output columns.
constexpr const char* kOutputHeader = "t,qw,qx,qy,qz,roll,pitch,yaw,bgx,bgy,bgz,px,py,pz,vx,vy,vz";

// One output row per log row. The attitude filter initialises on the first row with a magnetometer
// sample (attitude cells are empty before it); the position filter on the first vision fix (position
// and velocity cells are empty before it).
// track (may be null) receives every row's estimate.
ReplaySummary replay(const std::vector<LogRow>& rows, const ReplayOptions& options, std::ostream& out,
                     std::vector<Estimate>* track = nullptr);

}  // namespace quad::replay
