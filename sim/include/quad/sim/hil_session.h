// One HIL run: the vehicle, its sensors and links, the firmware process, the scenario's schedule, the
// outputs. The protocol is docs/hil-protocol.md; the lockstep exchange is
//   HIL_SENSOR (t) -> firmware runs one iteration -> HIL_ACTUATOR_CONTROLS (t) -> physics t .. t + T,
// with the motor commands taking effect when the answer's last byte has arrived: UART0 is paced at its baud
// in simulated time both ways, the firmware's bytes of each exchange counted (summary.json links).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quad/sim/scenario.h"
#include "quad/sim/udp_link.h"

namespace quad::sim {

// Called once per rendered frame (30 fps of simulated time) with the vehicle's MuJoCo state.
class Vehicle;
using FrameCallback = std::function<void(Vehicle&)>;

struct SessionOptions {
  std::string out_dir;                     // the run folder (created)
  std::vector<std::string> firmware_argv;  // the sim appends the port and params arguments
  bool realtime = false;                   // wall-clock pacing instead of lockstep
  bool progress = true;                    // the progress line on stderr
  double answer_timeout_s = 10.0;          // lockstep: how long to wait for HIL_ACTUATOR_CONTROLS (wall time)
  double frame_rate_hz = 30.0;             // for on_frame
  FrameCallback on_frame;                  // optional (--record)
  // The ground side of the radio as a serial port for outside programs (the vision station, a ground
  // station): a symlink at this path to a pseudo-terminal. Frames written there cross the emulated
  // radio to UART2; what the firmware sends on UART2 comes out there. Empty: no ground port.
  std::string ground_port_link;
  // A ground station over UDP (quad/sim/udp_link.h): the frames coming out of the ground side of the
  // radio go to it, its datagrams enter the radio there, like the ground port's frames.
  std::optional<UdpEndpoint> gcs_udp;
  // RUN/link.tlog: every frame at the ground side of the radio, both ways (quad/link/tlog.h).
  bool link_record = true;
  // The vision station command, used when the scenario renders the cameras (`camera: {enabled: true}`):
  // the sim appends --calib FILE --settings FILE --source sim:SOCKET --out PTY --baud B --status-s 10 --timeout-ms 60000
  // (quad/sim/station_loop.h).
  std::vector<std::string> station_argv;
  // The station's calibration file; empty: `vision_station calibrate` on chessboards the simulator
  // renders, cached in station_calibration_cache (empty: station_calibration/ beside the station).
  std::string station_calibration, station_calibration_cache;
  // The ground-camera station's room calibration (ground_cameras.enabled); empty: `vision_station
  // calibrate-room` on boards the simulator renders, cached in station_calibration_cache.
  std::string room_calibration;
  const std::atomic<bool>* stop = nullptr; // set (e.g. by SIGINT) to end the run early
};

struct SessionResult {
  bool complete = false;
  std::string reason;  // why it ended early
  double sim_time_s = 0.0;
  double wall_time_s = 0.0;
  bool crashed = false;
};

SessionResult run_session(const Scenario& scenario, const SessionOptions& options);

}  // namespace quad::sim
