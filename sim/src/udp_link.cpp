#include "quad/sim/udp_link.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace quad::sim {

UdpEndpoint parse_udp_endpoint(const std::string& text) {
  const std::string prefix = "udp:";
  if (text.compare(0, prefix.size(), prefix) != 0)
    throw std::invalid_argument("'" + text + "': a ground station link is udp:HOST:PORT (e.g. udp:127.0.0.1:14550)");
  const std::string rest = text.substr(prefix.size());
  const size_t colon = rest.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == rest.size())
    throw std::invalid_argument("'" + text + "': expected udp:HOST:PORT");
  UdpEndpoint e;
  e.host = rest.substr(0, colon);
  const std::string port = rest.substr(colon + 1);
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (*end != '\0' || p < 1 || p > 65535)
    throw std::invalid_argument("'" + text + "': the port '" + port + "' is not a number in 1..65535");
  e.port = static_cast<int>(p);
  return e;
}

UdpLink::UdpLink(const UdpEndpoint& to) : configured_(to.host + ":" + std::to_string(to.port)) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int status = getaddrinfo(to.host.c_str(), std::to_string(to.port).c_str(), &hints, &found);
  if (status != 0 || !found)
    throw std::runtime_error("udp:" + configured_ + ": cannot resolve '" + to.host + "': " + gai_strerror(status));
  std::memcpy(&peer_, found->ai_addr, sizeof peer_);
  freeaddrinfo(found);
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error("udp:" + configured_ + ": cannot open a socket: " + std::strerror(errno));
  sockaddr_in local{};
  local.sin_family = AF_INET;
  local.sin_addr.s_addr = htonl(INADDR_ANY);
  socklen_t length = sizeof local;
  if (bind(fd_, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0 ||
      getsockname(fd_, reinterpret_cast<sockaddr*>(&local), &length) != 0) {
    const std::string reason = std::strerror(errno);
    close(fd_);
    throw std::runtime_error("udp:" + configured_ + ": cannot bind a local port: " + reason);
  }
  local_port_ = ntohs(local.sin_port);
}

UdpLink::~UdpLink() {
  if (fd_ >= 0) close(fd_);
}

void UdpLink::send(const uint8_t* data, size_t size) {
  const ssize_t n = sendto(fd_, data, size, MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&peer_), sizeof peer_);
  if (n == static_cast<ssize_t>(size)) {
    ++stats_.datagrams_sent;
    stats_.bytes_sent += size;
  } else {
    ++stats_.datagrams_dropped;  // EAGAIN, or an ICMP error of an earlier datagram reported here
  }
}

size_t UdpLink::receive(uint8_t* out, size_t capacity) {
  for (;;) {
    sockaddr_in from{};
    socklen_t length = sizeof from;
    const ssize_t n = recvfrom(fd_, out, capacity, MSG_TRUNC, reinterpret_cast<sockaddr*>(&from), &length);
    if (n < 0) {
      if (errno == EINTR) continue;
      return 0;  // nothing waiting (or an ICMP error of a datagram sent to a closed port: nobody listens yet)
    }
    if (n == 0) continue;  // an empty datagram carries nothing
    ++stats_.datagrams_received;
    stats_.bytes_received += static_cast<uint64_t>(n);
    if (from.sin_addr.s_addr != peer_.sin_addr.s_addr || from.sin_port != peer_.sin_port) {
      peer_ = from;
      ++stats_.peer_changes;
    }
    return std::min(static_cast<size_t>(n), capacity);
  }
}

std::string UdpLink::peer() const {
  char address[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &peer_.sin_addr, address, sizeof address);
  return std::string(address) + ":" + std::to_string(ntohs(peer_.sin_port));
}

}  // namespace quad::sim
