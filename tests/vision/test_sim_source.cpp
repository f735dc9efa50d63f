// The sim: source against a scripted simulator end of the socket (sim_protocol.h): frames arrive with
// their capture time and sequence, each is answered with the processing time and the fix count after the
// station's output, a malformed header is an error naming the problem, and closing the socket ends it.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <string>

#include "quad/vision/frame_source.h"
#include "quad/vision/sim_protocol.h"
#include "quad/vision/sim_source.h"

namespace quad::vision {
namespace {

namespace wire = sim_protocol;

// The simulator's end: listens, accepts the source's connection.
class FakeSimulator {
 public:
  FakeSimulator() : path_("/tmp/quad_vision_test_" + std::to_string(getpid()) + ".sock") {
    listen_ = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::memcpy(a.sun_path, path_.c_str(), path_.size());
    ::unlink(path_.c_str());
    EXPECT_EQ(::bind(listen_, reinterpret_cast<const sockaddr*>(&a), sizeof a), 0);
    EXPECT_EQ(::listen(listen_, 1), 0);
  }
  ~FakeSimulator() {
    if (fd_ >= 0) ::close(fd_);
    ::close(listen_);
    ::unlink(path_.c_str());
  }
  const std::string& path() const { return path_; }
  void accept() { fd_ = ::accept(listen_, nullptr, nullptr); }
  void send_pair(uint64_t sequence, int64_t t_us, uint8_t left_grey, uint8_t right_grey, uint32_t magic = wire::kFrameMagic) {
    wire::FrameHeader h;
    h.magic = magic;
    h.width = 8;
    h.height = 4;
    h.sequence = sequence;
    h.capture_time_us = t_us;
    std::string bytes(reinterpret_cast<const char*>(&h), sizeof h);
    bytes += std::string(32, static_cast<char>(left_grey)) + std::string(32, static_cast<char>(right_grey));
    ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), 0), static_cast<ssize_t>(bytes.size()));
  }
  wire::FrameAnswer answer() {
    wire::FrameAnswer a;
    EXPECT_EQ(::recv(fd_, &a, sizeof a, MSG_WAITALL), static_cast<ssize_t>(sizeof a));
    return a;
  }
  void close() {
    ::close(fd_);
    fd_ = -1;
  }

 private:
  std::string path_;
  int listen_ = -1, fd_ = -1;
};

TEST(SimSource, DeliversPairsAndAnswersEach) {
  FakeSimulator sim;
  std::unique_ptr<FrameSource> source = make_frame_source("sim:" + sim.path());
  sim.accept();
  EXPECT_TRUE(source->vehicle_clock());
  StereoFrame frame;
  EXPECT_EQ(source->read(frame, std::chrono::milliseconds(20)), ReadStatus::kNoFrame);  // nothing sent yet

  sim.send_pair(7, 1'234'567, 10, 20);
  ASSERT_EQ(source->read(frame, std::chrono::milliseconds(1000)), ReadStatus::kFrame);
  EXPECT_EQ(frame.sequence, 7u);
  EXPECT_EQ(frame.capture_time_us, 1'234'567);
  ASSERT_EQ(frame.left.size(), cv::Size(8, 4));
  EXPECT_EQ(frame.left.type(), CV_8UC1);
  EXPECT_EQ(frame.left.at<uint8_t>(3, 7), 10);
  EXPECT_EQ(frame.right.at<uint8_t>(0, 0), 20);
  source->processed(frame, 812.5);
  source->answered(true, 3);
  const wire::FrameAnswer a = sim.answer();
  EXPECT_EQ(a.magic, wire::kAnswerMagic);
  EXPECT_EQ(a.sequence, 7u);
  EXPECT_EQ(a.fix_found, 1u);
  EXPECT_EQ(a.fixes_sent, 3u);
  EXPECT_DOUBLE_EQ(a.processing_us, 812.5);

  // A second pair: the answer carries that pair's own figures.
  sim.send_pair(9, 1'300'000, 30, 40);
  ASSERT_EQ(source->read(frame, std::chrono::milliseconds(1000)), ReadStatus::kFrame);
  EXPECT_EQ(frame.sequence, 9u);
  source->processed(frame, 100.0);
  source->answered(false, 3);
  const wire::FrameAnswer b = sim.answer();
  EXPECT_EQ(b.sequence, 9u);
  EXPECT_EQ(b.fix_found, 0u);
  EXPECT_DOUBLE_EQ(b.processing_us, 100.0);

  sim.close();
  EXPECT_EQ(source->read(frame, std::chrono::milliseconds(1000)), ReadStatus::kEnd);
  EXPECT_EQ(source->read(frame, std::chrono::milliseconds(1000)), ReadStatus::kEnd);
}

TEST(SimSource, MalformedHeaderIsAnError) {
  FakeSimulator sim;
  std::unique_ptr<FrameSource> source = make_frame_source("sim:" + sim.path());
  sim.accept();
  sim.send_pair(0, 0, 1, 2, 0xDEADBEEF);
  StereoFrame frame;
  try {
    source->read(frame, std::chrono::milliseconds(1000));
    FAIL() << "no error";
  } catch (const FrameSourceError& e) {
    EXPECT_NE(std::string(e.what()).find("malformed frame header"), std::string::npos) << e.what();
  }
}

TEST(SimSource, BadSpecsNameTheProblem) {
  EXPECT_THROW(make_frame_source("sim:"), FrameSourceError);
  try {
    make_sim_source("/tmp/quad_no_such_simulator_socket", std::chrono::milliseconds(100));
    FAIL() << "no error";
  } catch (const FrameSourceError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot connect to the simulator"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace quad::vision
