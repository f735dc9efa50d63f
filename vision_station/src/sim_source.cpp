#include "quad/vision/sim_source.h"

#include "quad/vision/sim_protocol.h"
#include "quad/vision/sim_socket.h"

namespace quad::vision {
namespace {

namespace wire = sim_protocol;

class SimSource : public FrameSource {
 public:
  SimSource(const std::string& path, std::chrono::milliseconds connect_timeout)
      : socket_(SimSocket::connect<FrameSourceError>(path, connect_timeout)) {}

  ReadStatus read(StereoFrame& frame, std::chrono::milliseconds timeout) override {
    if (ended_) return ReadStatus::kEnd;
    if (!socket_.wait_readable(timeout)) return ReadStatus::kNoFrame;
    wire::FrameHeader header;
    if (!socket_.receive(&header, sizeof header)) return end();
    if (header.magic != wire::kFrameMagic || header.width == 0 || header.height == 0 || header.width > 8192 ||
        header.height > 8192) {
      throw FrameSourceError("sim:" + socket_.path() + ": malformed frame header (not a quad_sim camera stream?)");
    }
    const int w = static_cast<int>(header.width), h = static_cast<int>(header.height);
    frame.left.create(h, w, CV_8UC1);
    frame.right.create(h, w, CV_8UC1);
    if (!socket_.receive(frame.left.data, frame.left.total()) ||
        !socket_.receive(frame.right.data, frame.right.total()))
      return end();
    frame.capture_time_us = header.capture_time_us;
    frame.sequence = header.sequence;
    frame.label.clear();
    answer_ = wire::FrameAnswer{};
    answer_.sequence = header.sequence;
    return ReadStatus::kFrame;
  }

  void processed(const StereoFrame&, double processing_us) override { answer_.processing_us = processing_us; }

  void answered(bool fix_found, uint64_t fixes_sent_total) override {
    answer_.fix_found = fix_found ? 1u : 0u;
    answer_.fixes_sent = fixes_sent_total;
    if (!socket_.send(&answer_, sizeof answer_)) ended_ = true;  // the simulator has gone
  }

  bool vehicle_clock() const override { return true; }
  std::string health() const override { return "sim:" + socket_.path() + ": the simulator sent no frame"; }

 private:
  ReadStatus end() {
    ended_ = true;
    return ReadStatus::kEnd;
  }
  SimSocket socket_;
  bool ended_ = false;
  wire::FrameAnswer answer_;
};

}  // namespace

std::unique_ptr<FrameSource> make_sim_source(const std::string& path, std::chrono::milliseconds connect_timeout) {
  return std::make_unique<SimSource>(path, connect_timeout);
}

}  // namespace quad::vision
