// The vision station in the loop: the rendered stereo pairs go to a `vision_station run
// --source sim:SOCKET` child process, its LANDING_TARGET frames come back on its radio port (a pty the
// simulator reads) and cross the emulated radio to the firmware.
//
// Lockstep accounting: a pair captured at t_c is sent at once; the simulator keeps stepping until
// t_c + `vision.latency_s`, then waits for the station's answer to that pair (fix or no fix) and puts
// the station's output into the radio at exactly t_c + latency. The station's measured processing time
// is recorded (summary.json) but does not move the release time: the wall clock of a loaded machine
// would make the log differ between runs of one seed. `late_answers` counts the pairs whose measured
// processing time exceeded the configured latency, i.e. where the accounting was optimistic.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/sim/pty.h"
#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"
#include "quad/sim/station_channel.h"
#include "quad/sim/stereo_camera.h"

namespace quad::sim {

// Figures of the station over a run.
struct StationFigures {
  uint64_t pairs_captured = 0, pairs_lost = 0, pairs_answered = 0, fixes = 0;
  uint64_t covariances = 0;            // LANDING_TARGET_COVARIANCE frames released to the radio
  std::vector<double> fix_error_m;     // |LANDING_TARGET − truth at capture|, body FRD, per fix
  std::vector<double> processing_us;   // the station's own measurement, per answered pair
  uint64_t late_answers = 0;           // processing time > the configured latency
};

struct StationLoopOptions {
  std::string calibration_file;   // the station's calibration; empty: from rendered chessboards (cached)
  std::string calibration_cache;  // where those are cached; empty: station_calibration/ beside the station
  std::function<void(const std::string&)> progress = [](const std::string&) {};
};

class StationLoop {
 public:
  // Starts the station (`station_argv` + --calib --settings --source --out --baud --status-s --timeout-ms)
  // with RUN/station_calib.yaml (made by `vision_station calibrate` on chessboards rendered through
  // `rig`, quad/sim/station_calibration.h) and RUN/station_settings.yaml (the left camera's mount and
  // the scenario's station_settings), and waits (10 s at most) for it to connect.
  StationLoop(const Scenario& scenario, const SimStereoRig& rig, const std::string& out_dir,
              const std::vector<std::string>& station_argv, const StationLoopOptions& options = StationLoopOptions());
  StationLoop(const StationLoop&) = delete;
  StationLoop& operator=(const StationLoop&) = delete;

  using RadioSink = std::function<void(double when, const uint8_t* data, size_t length)>;
  // Every physics step, with the truth at time t: captures a pair when one is due, and hands the
  // station's output for pairs whose release time has come to `to_radio`. Throws StationError when the
  // station dies or does not answer within 10 s.
  // `decoy_ne`: a second star-like shape on the floor at this north/east position (fault campaign).
  void update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool star_hidden,
              const RadioSink& to_radio, const std::optional<Eigen::Vector2d>& decoy_ne = std::nullopt);

  const StationFigures& figures() const { return figures_; }
  // Ends the stream (the station then exits) and waits for the process.
  void finish() { station_.finish(); }

 private:
  struct Pending {
    uint64_t sequence;
    double capture_t;
    Eigen::Vector3d star_body_frd;  // truth at capture
  };
  struct Timed {
    double t;
    VehiclePose pose;
  };
  VehiclePose pose_at(double t) const;  // interpolated in the recent history
  void send_pair(uint64_t sequence, double t);
  void collect(const Pending& pending, const RadioSink& to_radio);

  const Scenario& s_;
  StereoCameraRenderer renderer_;
  Rng loss_rng_;
  Pty port_;  // the station's radio (its --out)
  StationChannel station_;  // after port_: the station ends before its radio closes
  // The dialect too: LANDING_TARGET_COVARIANCE follows each LANDING_TARGET.
  quad::mavlink::Parser parser_{quad::mavlink::dialect_message_info};
  std::deque<std::vector<uint8_t>> frames_;  // parsed from the port, not yet released
  uint64_t frames_read_ = 0;
  // The station follows each fix with its covariances (send_covariance, default 1): a pair's output is
  // complete when both have been read, so that both leave at the pair's release time in every run.
  bool expect_covariance_ = true;
  uint64_t covariances_read_ = 0;
  double next_capture_t_ = 0.0;
  uint64_t next_sequence_ = 0;
  std::deque<Pending> pending_;
  std::deque<Timed> history_;
  cv::Mat left_, right_;
  StationFigures figures_;
};

}  // namespace quad::sim
