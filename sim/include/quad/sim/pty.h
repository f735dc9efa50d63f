// A pseudo-terminal pair standing in for one UART: the firmware opens the slave path as its serial port,
// the simulator reads and writes the master. Both ends are raw (no echo, no line discipline); the baud
// setting is recorded but a pty does not pace bytes, which is SerialLine's job.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace quad::sim {

class Pty {
 public:
  explicit Pty(int baud);
  ~Pty();
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;

  const std::string& slave_path() const { return slave_path_; }
  int master_fd() const { return master_; }

  // Writes every byte, waiting while the pty's buffer is full (the firmware reads it).
  void write_all(const uint8_t* data, size_t length);
  // Writes what the pty's buffer takes now and drops the rest (a port nobody may be reading, as a serial
  // line with no listener loses its bytes). Returns the number of bytes dropped.
  size_t write_or_drop(const uint8_t* data, size_t length);
  // Reads what is available without blocking; 0 when nothing is.
  size_t read_some(uint8_t* out, size_t capacity);
  // Waits up to timeout_ms for bytes to read; false on timeout.
  bool wait_readable(int timeout_ms) const;
  // Bytes written to the master that the firmware has not read yet (FIONREAD on the slave side). The
  // kernel moves written bytes to the slave from a work queue; this first forces that move (a poll on
  // the slave runs it synchronously), so the count is exact.
  int unread_by_peer() const;

 private:
  int master_ = -1;
  int slave_ = -1;  // kept open so the master never sees a hang-up before the firmware opens the slave
  std::string slave_path_;
};

}  // namespace quad::sim
