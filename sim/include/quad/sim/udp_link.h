// A ground station over UDP, as PX4's and ArduPilot's SITL offer one: the simulator sends the frames
// that come out of the ground side of the radio to HOST:PORT (QGroundControl and MAVProxy listen on
// 14550) and takes datagrams from whoever sends to its socket, so a ground station connects with no
// setting. Once a peer has spoken, frames go to the peer that sent last (normally the same address).
#pragma once

#include <netinet/in.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace quad::sim {

struct UdpEndpoint {
  std::string host;  // a name or an IPv4 address
  int port = 0;
};

// "udp:HOST:PORT" (the form PX4, ArduPilot and MAVProxy use). Throws std::invalid_argument naming the
// text and what is wrong.
UdpEndpoint parse_udp_endpoint(const std::string& text);

struct UdpLinkStats {
  uint64_t datagrams_sent = 0, bytes_sent = 0;
  uint64_t datagrams_dropped = 0;  // the socket's buffer was full or the send failed (as a lossy link)
  uint64_t datagrams_received = 0, bytes_received = 0;
  uint64_t peer_changes = 0;       // the sender of the datagrams received changed
};

class UdpLink {
 public:
  // Resolves the host (IPv4) and opens a non-blocking socket on an ephemeral port of every interface.
  // Throws std::runtime_error naming the endpoint.
  explicit UdpLink(const UdpEndpoint& to);
  ~UdpLink();
  UdpLink(const UdpLink&) = delete;
  UdpLink& operator=(const UdpLink&) = delete;

  // One datagram to the peer; never blocks (a full socket buffer drops it).
  void send(const uint8_t* data, size_t size);
  // One waiting datagram into out (truncated to capacity); 0 when none is waiting.
  size_t receive(uint8_t* out, size_t capacity);

  // "ADDRESS:PORT" of where the datagrams go now.
  std::string peer() const;
  std::string configured() const { return configured_; }
  int local_port() const { return local_port_; }
  const UdpLinkStats& stats() const { return stats_; }

 private:
  int fd_ = -1;
  sockaddr_in peer_{};
  std::string configured_;
  int local_port_ = 0;
  UdpLinkStats stats_;
};

}  // namespace quad::sim
