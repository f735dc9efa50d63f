// The ground-camera station in the loop: the room cameras (quad/sim/ground_camera.h) render every
// vehicle they see, the frame sets go to a `vision_station track --source sim:SOCKET` child process, its
// fixes (VISION_POSITION_ESTIMATE, one radio port per vehicle: pseudo-terminals the simulator reads)
// come back and cross each vehicle's emulated radio to its firmware.
//
// Lockstep accounting, as the onboard cameras' station loop (quad/sim/station_loop.h): a frame set whose
// last frame is captured at t_c is sent at once; the simulator keeps stepping until t_c +
// `ground_cameras.latency_s`, then waits for the station's answer to that set and puts each vehicle's fix
// into its radio at exactly that time. The station's measured processing time is recorded, not used.
// The trigger: triggered cameras capture together; free-running cameras capture at their own phases, a
// set being each camera's next frame, and every frame carries its own capture time.
//
// The loop takes the vehicles as a list (poses, marker layouts, ids), so a scenario with several vehicles
// hands it all of them; it scores the station's association against the rendered truth.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/link/mavlink.h"
#include "quad/sim/ground_camera.h"
#include "quad/sim/pty.h"
#include "quad/sim/rng.h"
#include "quad/sim/run_output.h"
#include "quad/sim/station_channel.h"

namespace quad::vision::ground_sim_protocol {
struct VehicleReport;
}

namespace quad::sim {

// One vehicle's share of the ground-camera figures (summary.json "vehicles.NAME.ground_station").
struct GroundVehicleFigures {
  uint64_t fixes = 0, pixels_checked = 0, association_errors = 0;
  uint64_t ambiguous_sets = 0;         // sets in which the station put this vehicle's tracks in a shared gate
  uint64_t ambiguous_gates = 0, epipolar_resolutions = 0;
  std::vector<double> fix_error_m, fix_latency_s;
};

// Figures of the ground-camera station over a run (summary.json "ground_station").
struct GroundCameraFigures {
  uint64_t sets_captured = 0, sets_lost = 0, sets_answered = 0, fixes = 0, late_answers = 0;
  std::vector<double> processing_us, cpu_us;   // the station's own measurement, per answered set
  std::vector<double> capture_skew_us;         // per set: latest − earliest capture time of its frames
  std::vector<double> fix_error_m;             // |fix − truth at the fix's time| per vehicle fix
  std::vector<double> fix_latency_s;           // the fix's capture time to its arrival at the firmware's UART2
  std::map<int, uint64_t> fixes_per_vehicle;
  uint64_t pixels_checked = 0;                 // associated detections compared with the rendered truth
  uint64_t association_errors = 0;             // ... nearer another vehicle's marker or off their own
  uint64_t ambiguous_sets = 0;                 // sets with at least one shared gate (any vehicle)
  uint64_t epipolar_sets = 0;                  // sets with at least one gate settled by the epipolar constraint
  uint64_t ambiguous_gates = 0, epipolar_resolutions = 0;  // summed over the vehicles' reports
  std::map<int, GroundVehicleFigures> per_vehicle;          // by vehicle id
};

// summary.json "ground_station" (the whole rig) and a vehicle's share of it.
Json ground_station_json(const GroundCameraFigures& figures, const GroundCameraParams& params);
Json ground_vehicle_json(const GroundVehicleFigures& figures);

// The tracker's vehicles file (`track --vehicles`): the first vehicle's marker layout as the common one,
// and each vehicle's id, start pose (which seed 003 takes as known) and own marker layout.
void write_ground_vehicles_file(const std::string& path, const std::vector<MarkedVehicle>& start);

struct GroundCameraLoopOptions {
  std::string room_file;    // the station's room calibration; empty: from rendered boards (cached)
  std::string room_cache;   // where those are cached; empty: station_calibration/ beside the station
  std::function<void(const std::string&)> progress = [](const std::string&) {};
};

class GroundCameraLoop {
 public:
  // Starts `station_argv` (ending in `run`, replaced by `track`) with RUN/room_calib.yaml and
  // RUN/ground_vehicles.yaml (the vehicles' ids, start poses and marker layout), one radio pty per
  // vehicle, and waits (10 s at most) for it to connect.
  GroundCameraLoop(const GroundCameraParams& params, uint64_t seed, int radio_baud, const std::vector<MarkedVehicle>& start,
                   const std::string& out_dir, const std::vector<std::string>& station_argv,
                   const GroundCameraLoopOptions& options = GroundCameraLoopOptions());
  GroundCameraLoop(const GroundCameraLoop&) = delete;
  GroundCameraLoop& operator=(const GroundCameraLoop&) = delete;

  using RadioSink = std::function<void(int vehicle_id, double when, const uint8_t* data, size_t length)>;
  // Every physics step with the vehicles' truth at time t (the same order and ids as `start`): captures
  // the frames due, sends complete sets, hands released fixes to `to_radio`. Throws StationError when the
  // station dies or does not answer within 10 s.
  void update(double t, const std::vector<MarkedVehicle>& vehicles, const RadioSink& to_radio);
  // Bytes of vehicle `vehicle_id`'s radio uplink handed to its firmware at time t (fix latency).
  void delivered(int vehicle_id, double t, const uint8_t* data, size_t length);

  const GroundCameraFigures& figures() const { return figures_; }
  const GroundCameraParams& params() const { return p_; }
  int station_pid() const { return station_.pid(); }
  void finish() { station_.finish(); }

 private:
  struct Pending {
    uint64_t sequence = 0;
    double complete_t = 0.0;
    std::vector<int64_t> capture_us;
    std::vector<MarkerViews> views;                  // per camera
    std::vector<Eigen::Vector3d> truth_ned;          // per vehicle, mean over the frames' capture times
    bool lost = false;
  };
  struct Link {
    std::unique_ptr<Pty> port;
    quad::mavlink::Parser parser;
    std::deque<std::vector<uint8_t>> frames;  // parsed fixes, not yet released
    quad::mavlink::Parser delivered;          // the uplink's bytes at the firmware
  };
  void capture(size_t camera, double t, const std::vector<MarkedVehicle>& vehicles);
  void send_set(const Pending& set);
  void collect(const Pending& set, const RadioSink& to_radio);
  void score(const Pending& set, const std::vector<quad::vision::ground_sim_protocol::VehicleReport>& reports);
  double capture_time(size_t camera, uint64_t n) const;

  GroundCameraParams p_;
  GroundCameraRenderer renderer_;
  Rng loss_rng_;
  std::vector<int> ids_;
  std::map<int, Link> links_;
  StationChannel station_;  // after links_: the station ends before its radios close
  uint64_t frames_read_ = 0;
  uint64_t next_set_ = 0;
  std::vector<uint64_t> next_frame_;   // per camera: the set its next capture belongs to
  std::vector<cv::Mat> images_;        // the set being captured
  Pending filling_;
  std::deque<Pending> pending_;
  GroundCameraFigures figures_;
};

}  // namespace quad::sim
