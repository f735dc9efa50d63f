// `vision_station track --source sim:SOCKET` against scenes it did not make: the test plays the
// simulator's end of the wire (ground_sim_protocol.h) with frame sets drawn by tools/ground_eval (its own
// cameras, balls and truth), on a room file `calibrate-room` made from that generator's boards. Each
// vehicle's VISION_POSITION_ESTIMATE must arrive on its own radio port (a pty per vehicle), carry the
// set's time (the mean of free-running frames' capture times) and the vehicle's position and attitude; the
// answers must name the set and count the frames written. Bad live options are errors naming them.
#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "ground_scenes.h"
#include "quad/link/mavlink.h"
#include "quad/vision/ground/ground_sim_protocol.h"
#include "raw_pty.h"
#include "command_output.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;
namespace wire = quad::vision::ground_sim_protocol;
namespace mav = quad::mavlink;
using namespace ground_eval;

std::string run(const std::string& command, int* status_out = nullptr) {
  const quad::test::CommandOutput r = quad::test::run_command(command);
  if (status_out) *status_out = r.status;
  else if (r.status != 0) throw std::runtime_error(command + " failed (" + std::to_string(r.status) + "):\n" + r.out);
  return r.out;
}

bool recv_exact(int fd, void* data, size_t length, int timeout_ms) {
  auto* p = static_cast<uint8_t*>(data);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (length > 0) {
    pollfd pfd{fd, POLLIN, 0};
    if (::poll(&pfd, 1, 50) <= 0) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      continue;
    }
    const ssize_t n = ::recv(fd, p, length, 0);
    if (n <= 0) return false;
    p += n;
    length -= static_cast<size_t>(n);
  }
  return true;
}

void send_exact(int fd, const void* data, size_t length) {
  const auto* p = static_cast<const uint8_t*>(data);
  while (length > 0) {
    const ssize_t n = ::send(fd, p, length, MSG_NOSIGNAL);
    ASSERT_GT(n, 0) << std::strerror(errno);
    p += n;
    length -= static_cast<size_t>(n);
  }
}

// ZYX Euler angles of R (roll, pitch, yaw).
cv::Vec3d euler(const cv::Matx33d& R) {
  return {std::atan2(R(2, 1), R(2, 2)), -std::asin(R(2, 0)), std::atan2(R(1, 0), R(0, 0))};
}

class GroundLive : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("ground_live_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    cameras_ = new std::vector<SceneCamera>(make_room_cameras(RoomSpec()));
    // The room file of the generator's fixed board set, made once per build of the station (each test
    // runs in a process of its own); calibrate-room itself is test_vision_ground_track's subject.
    const auto stamp = fs::last_write_time(VISION_STATION_EXE).time_since_epoch().count();
    const fs::path cached = fs::path(GROUND_LIVE_CACHE) / ("room-" + std::to_string(stamp) + "-" +
                                                          std::to_string(fs::file_size(VISION_STATION_EXE)) + ".yaml");
    if (!fs::exists(cached)) {
      write_calibration_set((*dir_ / "boards").string(), *cameras_, BoardSpec(), 12, 7);
      const std::string partial = room() + ".partial";
      run(std::string(VISION_STATION_EXE) + " calibrate-room --images " + (*dir_ / "boards").string() + " --out " + partial);
      fs::create_directories(cached.parent_path());
      fs::copy_file(partial, cached.string() + "." + std::to_string(::getpid()));
      fs::rename(cached.string() + "." + std::to_string(::getpid()), cached);  // atomic for a parallel test
    }
    fs::copy_file(cached, room());
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete cameras_;
  }
  static std::string room() { return (*dir_ / "room.yaml").string(); }

  // Plays the simulator for `frames` sets of the `pair` scene; camera 1's frames stamped `skew_us` after
  // camera 0's.
  void fly_pair(int frames, int64_t skew_us) {
    SceneOptions options;
    options.scenario = ground_eval::Scenario::kPair;
    options.frames = frames;
    options.seed = 5;
    const fs::path set = *dir_ / ("pair_" + std::to_string(skew_us));
    const std::vector<FrameTruth> truth = write_scene_set(set.string(), *cameras_, VehicleModel(), options);
    ASSERT_EQ(truth.front().vehicles.size(), 2u);

    const std::string socket_path = "/tmp/ground_live_" + std::to_string(::getpid()) + ".sock";
    const int listen_fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strcpy(address.sun_path, socket_path.c_str());
    ::unlink(socket_path.c_str());
    ASSERT_EQ(::bind(listen_fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    ASSERT_EQ(::listen(listen_fd, 1), 0);
    quad_test::RawPty radio1(true), radio2(true);
    ASSERT_FALSE(radio1.path.empty() || radio2.path.empty());
    const int ids[2] = {truth.front().vehicles[0].id, truth.front().vehicles[1].id};
    const std::string log = (set / "station.log").string();
    const std::string radio = std::to_string(ids[0]) + "=" + radio1.path + "," + std::to_string(ids[1]) + "=" + radio2.path;
    std::vector<std::string> args{VISION_STATION_EXE, "track", "--room", room(), "--vehicles", (set / "vehicles.yaml").string(),
                                  "--source", "sim:" + socket_path, "--radio", radio, "--baud", "57600"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ), 0);
    posix_spawn_file_actions_destroy(&actions);
    pollfd pfd{listen_fd, POLLIN, 0};
    ASSERT_GT(::poll(&pfd, 1, 10000), 0) << "the station did not connect";
    const int fd = ::accept(listen_fd, nullptr, nullptr);
    ASSERT_GE(fd, 0);

    mav::Parser parsers[2];
    uint64_t frames_seen = 0;
    int found = 0;
    for (size_t i = 0; i < truth.size(); ++i) {
      const FrameTruth& f = truth[i];
      std::ifstream list((set / "frames.csv").string());
      std::string line;
      for (size_t skip = 0; skip <= i + 1 && std::getline(list, line);) ++skip;  // header, then row i
      std::stringstream row(line);
      std::string time_field, image0, image1;
      std::getline(row, time_field, ',');
      std::getline(row, image0, ',');
      std::getline(row, image1, ',');
      const cv::Mat images[2] = {cv::imread((set / image0).string(), cv::IMREAD_COLOR),
                                 cv::imread((set / image1).string(), cv::IMREAD_COLOR)};
      ASSERT_FALSE(images[0].empty() || images[1].empty());
      wire::SetHeader header;
      header.cameras = 2;
      header.width = static_cast<uint32_t>(images[0].cols);
      header.height = static_cast<uint32_t>(images[0].rows);
      header.sequence = 100 + i;
      header.capture_time_us[0] = f.time_us;
      header.capture_time_us[1] = f.time_us + skew_us;
      send_exact(fd, &header, sizeof header);
      for (const cv::Mat& image : images) send_exact(fd, image.data, image.total() * image.elemSize());
      wire::SetAnswer answer;
      ASSERT_TRUE(recv_exact(fd, &answer, sizeof answer, 10000)) << "no answer to set " << i;
      EXPECT_EQ(answer.magic, wire::kAnswerMagic);
      EXPECT_EQ(answer.sequence, header.sequence);
      EXPECT_EQ(answer.fix_time_us, f.time_us + skew_us / 2);
      ASSERT_EQ(answer.vehicles, 2u);
      std::vector<wire::VehicleReport> reports(2);
      ASSERT_TRUE(recv_exact(fd, reports.data(), 2 * sizeof(wire::VehicleReport), 10000));
      // The frames written before the answer: read each vehicle's port until the count is reached.
      std::vector<mav::VisionPositionEstimate> got[2];
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
      while (frames_seen < answer.fixes_sent && std::chrono::steady_clock::now() < deadline) {
        for (int v = 0; v < 2; ++v) {
          uint8_t buf[1024];
          const ssize_t n = ::read(v == 0 ? radio1.master : radio2.master, buf, sizeof buf);
          if (n <= 0) continue;
          parsers[v].feed(buf, static_cast<size_t>(n), [&](const mav::Frame& frame) {
            mav::VisionPositionEstimate m;
            ASSERT_TRUE(frame.message_id == mav::VisionPositionEstimate::kId && mav::decode(frame, m));
            got[v].push_back(m);
            ++frames_seen;
          });
        }
      }
      ASSERT_EQ(frames_seen, answer.fixes_sent);
      for (int v = 0; v < 2; ++v) {
        const wire::VehicleReport& r = reports[static_cast<size_t>(v)];
        EXPECT_EQ(r.id, ids[v]);
        ASSERT_EQ(got[v].size(), r.found ? 1u : 0u) << "set " << i << " vehicle " << ids[v];
        if (!r.found) continue;
        ++found;
        const mav::VisionPositionEstimate& m = got[v].front();
        const VehicleState& s = f.vehicles[static_cast<size_t>(v)];
        EXPECT_EQ(m.usec, static_cast<uint64_t>(f.time_us + skew_us / 2));
        EXPECT_NEAR(m.x, s.ned[0], 0.005);
        EXPECT_NEAR(m.y, s.ned[1], 0.005);
        EXPECT_NEAR(m.z, s.ned[2], 0.005);
        EXPECT_NEAR(m.x, r.ned[0], 1e-6);
        const cv::Vec3d e = euler(s.R_IB);
        EXPECT_NEAR(m.roll, e[0], 0.02);
        EXPECT_NEAR(m.pitch, e[1], 0.02);
        EXPECT_NEAR(std::remainder(m.yaw - e[2], 2.0 * CV_PI), 0.0, 0.02);
        EXPECT_GT(m.covariance[0], 0.0f);   // x variance
        EXPECT_GT(m.covariance[15], 0.0f);  // roll variance (row 3 of the upper triangle)
        // Each associated pixel on its own ball (the generator's truth, visible or not).
        for (int k = 0; k < 4; ++k)
          for (int c = 0; c < 2; ++c) {
            if (std::isnan(r.pixels[k][c][0])) continue;
            const cv::Point2d px(r.pixels[k][c][0], r.pixels[k][c][1]);
            EXPECT_LT(cv::norm(px - f.markers[static_cast<size_t>(v)][static_cast<size_t>(c)][static_cast<size_t>(k)].pixel), 4.0);
          }
      }
    }
    EXPECT_GE(found, 2 * frames - 2);
    ::close(fd);  // the end of the stream: the station exits
    int status = -1;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    std::ifstream in(log);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("end of the simulator's stream after " + std::to_string(frames) + " frame sets"), std::string::npos) << text;
    ::close(listen_fd);
    ::unlink(socket_path.c_str());
  }

  static fs::path* dir_;
  static std::vector<SceneCamera>* cameras_;
};

fs::path* GroundLive::dir_ = nullptr;
std::vector<SceneCamera>* GroundLive::cameras_ = nullptr;

TEST_F(GroundLive, EachVehicleGetsItsFixOnItsOwnPort) { fly_pair(12, 0); }

TEST_F(GroundLive, FreeRunningFramesGiveTheMeanCaptureTime) { fly_pair(6, 10000); }

TEST_F(GroundLive, BadLiveOptionsAreErrorsNamingThem) {
  const std::string base = std::string(VISION_STATION_EXE) + " track --room " + room() + " --vehicles ";
  // A vehicles file of one vehicle (id 1) for these.
  const std::string vehicles = (*dir_ / "one.yaml").string();
  {
    std::ofstream v(vehicles);
    v << "%YAML:1.0\n---\nmarker_red: [0.22, 0, -0.02]\nmarker_green: [0, 0.22, -0.02]\nmarker_blue: [-0.22, 0, -0.02]\n"
         "marker_yellow: [0, -0.22, -0.07]\nvehicles:\n  - {id: 1, ned: [0, 0, -1], yaw_deg: 0}\n";
  }
  int status = 0;
  std::string out = run(base + vehicles + " --source files:/tmp", &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("--source 'files:/tmp': the live source of track is sim:SOCKET"), std::string::npos) << out;
  out = run(base + vehicles + " --source sim:/tmp/x.sock --frames f.csv", &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("--frames and --source exclude each other"), std::string::npos) << out;
  out = run(base + vehicles + " --source sim:/tmp/x.sock --radio 3=/dev/null", &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(out.find("vehicle 3 is not in the vehicles file"), std::string::npos) << out;
  out = run(base + vehicles + " --source sim:/tmp/x.sock --radio /dev/null --message att_pos_mocap", &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(out.find("--message 'att_pos_mocap': expected vision_position_estimate"), std::string::npos) << out;
  out = run(base + vehicles + " --source sim:/tmp/ground_live_nobody.sock --timeout-ms 200", &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(out.find("cannot connect to the simulator"), std::string::npos) << out;
}

}  // namespace
