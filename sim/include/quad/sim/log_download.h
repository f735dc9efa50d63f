// A ground station's log download (MAVLink log protocol: LOG_REQUEST_LIST, LOG_ENTRY, LOG_REQUEST_DATA,
// LOG_DATA, LOG_REQUEST_END) in simulated time, for the scenario command `log_download` (docs/simulator.md).
//
// It lists the logs, picks the one asked for (by default the newest: the open log, as far as the vehicle
// had written it when it answered the list), asks for its bytes from 0 (up to max_bytes), keeps every
// LOG_DATA that arrives wherever it falls, and when the stream ends or has been quiet for kQuietS asks
// again for the first range it still lacks, as quad_gs does. After kMaxIdleRequests requests in a row
// that brought nothing it gives up. What it received goes to a file; its figures to summary.json.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "quad/link/mavlink.h"

namespace quad::sim {

struct LogDownloadRequest {
  std::optional<uint16_t> id;          // none: the newest log
  std::optional<uint32_t> max_bytes;   // none: the whole log as listed
};

class LogDownload {
 public:
  static constexpr double kQuietS = 1.0;         // no LOG_ENTRY / LOG_DATA for this long: ask again
  static constexpr int kMaxIdleRequests = 10;

  // How the client's requests reach the vehicle (the radio, in quad_sim).
  struct Link {
    std::function<void(const mavlink::LogRequestList&, double t)> list;
    std::function<void(const mavlink::LogRequestData&, double t)> data;
    std::function<void(const mavlink::LogRequestEnd&, double t)> end;
  };

  explicit LogDownload(Link link) : link_(std::move(link)) {}

  void start(double t, const LogDownloadRequest& request);
  // Every frame from the vehicle (other messages are ignored).
  void on_frame(const mavlink::Frame& f, double t);
  // Once per control period: asks again after a quiet spell.
  void poll(double t);

  bool active() const { return state_ == State::kListing || state_ == State::kData; }
  bool complete() const { return state_ == State::kDone; }
  bool started() const { return state_ != State::kIdle; }
  uint16_t id() const { return id_; }
  uint32_t listed_size() const { return listed_size_; }
  uint32_t wanted() const { return wanted_; }
  uint64_t bytes_received() const { return bytes_received_; }   // first copies of each byte
  uint64_t frames_received() const { return frames_; }
  int data_requests() const { return data_requests_; }
  double started_s() const { return start_t_; }
  double data_started_s() const { return data_start_t_; }
  double finished_s() const { return end_t_; }
  // Log bytes per second from the first data request to the last byte.
  double rate_bytes_s() const;
  std::string failure() const { return failure_; }
  // The bytes from 0 up to the first one not received.
  std::vector<uint8_t> contiguous() const;
  // A line for events.log about the state reached.
  std::string describe() const;

 private:
  enum class State { kIdle, kListing, kData, kDone, kFailed };
  void request_list(double t);
  void request_missing(double t);
  void finish(double t);
  void fail(double t, const std::string& why);

  Link link_;
  LogDownloadRequest request_;
  State state_ = State::kIdle;
  std::vector<std::pair<uint16_t, uint32_t>> entries_;  // (id, size) as listed
  uint16_t num_logs_ = 0;
  uint16_t id_ = 0;
  uint32_t listed_size_ = 0, wanted_ = 0;
  std::vector<uint8_t> data_;
  std::vector<bool> have_;
  uint32_t first_missing_ = 0;
  uint64_t bytes_received_ = 0, frames_ = 0;
  int data_requests_ = 0, idle_requests_ = 0, list_requests_ = 0;
  bool progress_since_request_ = false;
  double last_heard_t_ = 0.0, start_t_ = 0.0, data_start_t_ = 0.0, end_t_ = 0.0, last_byte_t_ = 0.0;
  std::string failure_;
};

}  // namespace quad::sim
