// The station's end of the simulator's Unix stream socket, shared by the stereo source (sim_source.h)
// and the room-camera source (ground/ground_sim_source.h). Failures are thrown as the source's own
// exception type, with messages "sim:PATH: ...".
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace quad::vision {

class SimSocket {
 public:
  // Connects to the socket at `path`, retrying until `connect_timeout` while the simulator has not
  // created it yet; throws Error otherwise.
  template <class Error>
  static SimSocket connect(const std::string& path, std::chrono::milliseconds connect_timeout) {
    return SimSocket(path, connect_timeout, [](const std::string& message) { throw Error(message); });
  }
  ~SimSocket();
  SimSocket(const SimSocket&) = delete;
  SimSocket& operator=(const SimSocket&) = delete;

  const std::string& path() const { return path_; }
  // False only when nothing arrived within `timeout`; an error is left to the next receive.
  bool wait_readable(std::chrono::milliseconds timeout);
  // Fills all `length` bytes; false at the end of the stream (the simulator closed it).
  bool receive(void* data, size_t length);
  // Sends all `length` bytes; false if the simulator has gone.
  bool send(const void* data, size_t length);

 private:
  using Raise = void (*)(const std::string& message);  // throws the source's exception type
  SimSocket(const std::string& path, std::chrono::milliseconds connect_timeout, Raise raise);
  [[noreturn]] void fail(const std::string& what) const;

  std::string path_;
  Raise raise_;
  int fd_ = -1;
};

}  // namespace quad::vision
