// A station program (`vision_station run` or `track`) as a child process at the far end of a Unix stream
// socket: the simulator listens, starts the child with `--source sim:SOCKET`, sends it frames and reads
// its answers, every wait bounded by 10 s so that a dead or stalled station fails the run instead of
// hanging it.
#pragma once

#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "quad/sim/firmware_process.h"

namespace quad::sim {

struct StationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class StationChannel {
 public:
  // How long the station may take to connect, to read a frame and to answer one.
  static constexpr int kAnswerTimeoutMs = 10000;

  // Listens on a new socket of this run, /tmp/SOCKET_PREFIX-PID-N.sock. `program` names the station in
  // errors ("vision station").
  StationChannel(const std::string& program, const std::string& socket_prefix);
  ~StationChannel();  // finishes, then removes the socket
  StationChannel(const StationChannel&) = delete;
  StationChannel& operator=(const StationChannel&) = delete;

  const std::string& socket_path() const { return socket_path_; }

  // Starts `argv` with its output in `log_path` and waits (10 s at most) for it to connect.
  void start(const std::vector<std::string>& argv, const std::string& log_path);
  // `what_is_sent` names the data in errors ("a frame pair").
  void send_all(const void* data, size_t length, const char* what_is_sent);
  // `what` names the awaited data in errors ("its answer").
  void read_exact(void* data, size_t length, const char* what);
  // Ends the stream (the station then exits) and waits for the process, 1 s at most before ending it.
  void finish();
  // The station's process id while it runs, else -1.
  int pid() const;

 private:
  std::string program_;
  std::string socket_path_;
  std::string log_name_;  // the log file's name, for errors
  int listen_fd_ = -1, fd_ = -1;
  std::unique_ptr<FirmwareProcess> process_;
};

// The folder the station's calibrations are cached in: station_calibration/ beside the station executable
// (station_argv[0]), or in `out_dir` when the executable has no folder (found through PATH).
std::string default_station_calibration_cache(const std::vector<std::string>& station_argv, const std::string& out_dir);

}  // namespace quad::sim
