// The firmware's own estimator (fw::StateEstimator, library quad_state_estimator) run over a flight log
// as the application runs it: the logged parameters ('P' at log start, and each change where it was
// logged), the frame schedule of SYS_LOOP_HZ, every sensor_combined record as one iteration (its
// timestamp, gyro, accelerometer and dt) with the sensor_mag sample of the same timestamp, and every
// vision_fix with a position fused or queued at its capture time as FlightApp does.
//
// The log must hold the IMU at the loop rate (LOG_IMU_DIV 1) and start at boot, so that the boot
// calibration sees the samples it saw in flight; then the attitude equals the logged vehicle_attitude.q.
#pragma once

#include <ostream>

#include "ulog_reader.h"

namespace quad::replay {

struct FirmwareReplaySummary {
  int iterations = 0;
  int fixes = 0;                  // fixes handed to the filter
  int compared = 0;               // iterations with a logged vehicle_attitude of the same timestamp
  double max_q_difference = 0.0;  // largest |q_replay - q_logged| component over them (sign-aligned)
  double first_difference_t = -1.0;  // s, the first compared iteration whose difference exceeds the tolerance
  bool calibrated = false;        // the boot calibration finished within the log
  bool hovering_logged = false;   // sensor_combined carries the hovering flag the estimator was handed
};

// Writes one CSV row per iteration (replay.h's kOutputHeader; the gyro-bias cells empty: the estimator
// does not expose it). tolerance: the difference first_difference_t reports. Throws LogError naming the
// file on a missing topic or field, or a logged parameter the firmware refuses.
FirmwareReplaySummary replay_firmware(const ulog::File& log, double tolerance, std::ostream& out);

}  // namespace quad::replay
