// The live station's plumbing: a stalled source gives no fix and recovers; LANDING_TARGET and TIMESYNC
// on a pseudo-terminal decoded by the project's MAVLink parser; the command line end to end on rendered
// image files.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "quad/link/mavlink.h"
#include "quad/vision/fix_output.h"
#include "quad/vision/station.h"
#include "star_scenes.h"

namespace quad::vision {
namespace {

// Plays back a script: a pair, or a stall (kNoFrame).
class ScriptedSource : public FrameSource {
 public:
  std::deque<std::optional<std::pair<cv::Mat, cv::Mat>>> script;
  ReadStatus read(StereoFrame& frame, std::chrono::milliseconds) override {
    if (script.empty()) return ReadStatus::kEnd;
    auto next = std::move(script.front());
    script.pop_front();
    if (!next) return ReadStatus::kNoFrame;
    frame.left = next->first;
    frame.right = next->second;
    frame.capture_time_us = monotonic_us();
    return ReadStatus::kFrame;
  }
  void processed(const StereoFrame&, double processing_us) override { processing.push_back(processing_us); }
  std::vector<double> processing;
};

TEST(StationTest, StalledCameraGivesNoFixAndRecovers) {
  const StereoRig rig = thesis_stereo_rig();
  const StereoCalibration calibration = rectify(rig);
  cv::RNG rng(51);
  const auto scene = testing::random_star_scene(rig, rng, testing::StarSceneRanges{});
  ASSERT_TRUE(scene);
  ScriptedSource source;
  const auto pair = std::make_pair(scene->left, scene->right);
  source.script = {pair, pair, std::nullopt, std::nullopt, std::nullopt, pair};
  StereoStarLocator locator(calibration, LocatorSettings{});
  Station station(locator, source, std::chrono::milliseconds(10));
  std::vector<bool> found;
  for (StationStep step = station.step(); step.status != ReadStatus::kEnd; step = station.step()) {
    found.push_back(step.status == ReadStatus::kFrame && step.fix.found);
  }
  EXPECT_EQ(found, (std::vector<bool>{true, true, false, false, false, true}));
  // The source hears back about every processed frame (lockstep sources account the time).
  ASSERT_EQ(source.processing.size(), 3u);
  for (double us : source.processing) EXPECT_GT(us, 0.0);
}

TEST(StationTest, WrongImageSizeIsAClearError) {
  const StereoCalibration calibration = rectify(thesis_stereo_rig());
  ScriptedSource source;
  source.script = {std::make_pair(cv::Mat(480, 640, CV_8UC1, cv::Scalar(200)), cv::Mat(480, 640, CV_8UC1, cv::Scalar(200)))};
  StereoStarLocator locator(calibration, LocatorSettings{});
  Station station(locator, source, std::chrono::milliseconds(10));
  try {
    station.step();
    FAIL() << "640x480 accepted for a 728x488 calibration";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("640x480"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("728x488"), std::string::npos) << e.what();
  }
}

// video:L,R through cv::VideoCapture (OpenCV's built-in MJPEG/AVI codec): the grabber thread delivers
// every pair of a file, the star is found in each, and the end of the files ends the source.
TEST(StationTest, VideoSourceDeliversPairsUntilTheEnd) {
  const StereoRig rig = thesis_stereo_rig();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("vision_video_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string left_path = (dir / "left.avi").string(), right_path = (dir / "right.avi").string();
  {
    cv::VideoWriter left(left_path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0,
                         rig.image_size, true);
    cv::VideoWriter right(right_path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0,
                          rig.image_size, true);
    ASSERT_TRUE(left.isOpened() && right.isOpened());
    cv::RNG rng(71);
    for (int i = 0; i < 5; ++i) {
      const auto scene = testing::random_star_scene(rig, rng, testing::StarSceneRanges{});
      ASSERT_TRUE(scene);
      // Colour frames, as capture devices deliver them; the source converts to grey (thesis step 1).
      cv::Mat l, r;
      cv::cvtColor(scene->left, l, cv::COLOR_GRAY2BGR);
      cv::cvtColor(scene->right, r, cv::COLOR_GRAY2BGR);
      left.write(l);
      right.write(r);
    }
  }
  const std::unique_ptr<FrameSource> source = make_frame_source("video:" + left_path + "," + right_path);
  StereoStarLocator locator(rectify(rig), LocatorSettings{});
  Station station(locator, *source, std::chrono::milliseconds(2000));
  int frames = 0, fixes = 0;
  for (StationStep step = station.step(); step.status != ReadStatus::kEnd; step = station.step()) {
    ASSERT_EQ(step.status, ReadStatus::kFrame);
    ++frames;
    fixes += step.fix.found ? 1 : 0;
  }
  EXPECT_EQ(frames, 5);  // files deliver every pair
  EXPECT_EQ(fixes, frames);
  EXPECT_THROW(make_frame_source("video:" + (dir / "absent.avi").string() + "," + right_path), FrameSourceError);
  EXPECT_THROW(make_frame_source("video:" + left_path), FrameSourceError);
  EXPECT_THROW(make_frame_source("tcp:1234"), FrameSourceError);
  std::filesystem::remove_all(dir);
}

// A pseudo-terminal: the station opens the slave path, the test reads and writes the master side.
struct Pty {
  int master = -1;
  std::string slave;
  Pty() {
    master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (master >= 0 && grantpt(master) == 0 && unlockpt(master) == 0) slave = ptsname(master);
  }
  ~Pty() {
    if (master >= 0) close(master);
  }
  // Frames the master side has received so far.
  std::vector<std::pair<uint32_t, std::vector<uint8_t>>> drain(mavlink::Parser& parser) {
    std::vector<std::pair<uint32_t, std::vector<uint8_t>>> frames;
    uint8_t buffer[512];
    for (int idle = 0; idle < 20;) {
      const ssize_t n = ::read(master, buffer, sizeof buffer);
      if (n <= 0) {
        ++idle;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      parser.feed(buffer, static_cast<size_t>(n), [&](const mavlink::Frame& f) {
        frames.emplace_back(f.message_id, std::vector<uint8_t>(f.bytes, f.bytes + f.size));
        EXPECT_EQ(f.system_id, 1);
        EXPECT_EQ(f.component_id, mavlink::kCompIdVisualInertialOdometry);
      });
    }
    return frames;
  }
};

template <class Msg>
std::optional<Msg> decode_last(const std::vector<std::pair<uint32_t, std::vector<uint8_t>>>& frames) {
  for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
    if (it->first != Msg::kId) continue;
    mavlink::Parser parser;
    std::optional<Msg> out;
    parser.feed(it->second.data(), it->second.size(), [&](const mavlink::Frame& f) {
      Msg m;
      if (mavlink::decode(f, m)) out = m;
    });
    return out;
  }
  return std::nullopt;
}

TEST(FixLinkTest, LandingTargetInBodyFrdAndTimesyncOffset) {
  Pty pty;
  ASSERT_FALSE(pty.slave.empty());
  SerialPort port(pty.slave, 57600);
  FixLink link(port);
  mavlink::Parser parser;
  const CameraMount mount = thesis_camera_mount();
  StarFix fix;
  fix.found = true;
  fix.p_left = cv::Vec3d(0.2, -0.1, 1.5);

  // Before any TIMESYNC reply: station clock.
  const int64_t now = monotonic_us();
  link.poll(now);  // sends the first request
  ASSERT_TRUE(link.send(fix, mount, now - 20'000));
  auto frames = pty.drain(parser);
  const auto request = decode_last<mavlink::Timesync>(frames);
  ASSERT_TRUE(request);
  EXPECT_EQ(request->tc1, 0);
  const auto target = decode_last<mavlink::LandingTarget>(frames);
  ASSERT_TRUE(target);
  EXPECT_EQ(target->frame, 12);
  EXPECT_EQ(target->position_valid, 1);
  const cv::Vec3d body = camera_to_body(mount, fix.p_left);
  EXPECT_FLOAT_EQ(target->x, static_cast<float>(body[0]));
  EXPECT_FLOAT_EQ(target->y, static_cast<float>(body[1]));
  EXPECT_FLOAT_EQ(target->z, static_cast<float>(body[2]));
  EXPECT_NEAR(target->x, 0.057 + 0.1, 1e-6);   // camera −y (image up) is body forward
  EXPECT_NEAR(target->y, -0.057 + 0.2, 1e-6);  // camera +x is body right
  EXPECT_EQ(target->time_usec, static_cast<uint64_t>(now - 20'000));
  EXPECT_NEAR(target->distance, cv::norm(fix.p_left), 1e-5);

  // The vehicle answers the request with its clock 5 s ahead of ours.
  mavlink::Sender vehicle(1, 1);
  mavlink::Timesync reply;
  reply.ts1 = request->ts1;
  reply.tc1 = request->ts1 + 5'000'000'000LL;
  uint8_t out[mavlink::max_frame_length<mavlink::Timesync>()];
  const size_t n = vehicle.encode(reply, out, sizeof out);
  ASSERT_EQ(::write(pty.master, out, n), static_cast<ssize_t>(n));
  // And asks for ours.
  mavlink::Timesync ask;
  ask.ts1 = 123456789;
  const size_t m = vehicle.encode(ask, out, sizeof out);
  ASSERT_EQ(::write(pty.master, out, m), static_cast<ssize_t>(m));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const int64_t later = monotonic_us();
  link.poll(later);
  ASSERT_TRUE(link.synchronised());
  // offset = tc1 − (ts1 + now)/2: 5 s minus half the (test's) round trip.
  EXPECT_NEAR(static_cast<double>(link.offset_us()), 5e6 - (later - request->ts1 / 1000) / 2.0, 1000.0);
  ASSERT_TRUE(link.send(fix, mount, later));
  frames = pty.drain(parser);
  const auto answer = decode_last<mavlink::Timesync>(frames);
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->ts1, 123456789);
  EXPECT_EQ(answer->target_system, 1);
  EXPECT_EQ(answer->target_component, 1);
  EXPECT_NEAR(static_cast<double>(answer->tc1), later * 1000.0, 1e7);
  const auto synced = decode_last<mavlink::LandingTarget>(frames);
  ASSERT_TRUE(synced);
  EXPECT_EQ(static_cast<int64_t>(synced->time_usec), later + link.offset_us());
}

// The command line end to end: rendered pairs and the thesis calibration written to a folder.
class CommandLineTest : public ::testing::Test {
 protected:
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vision_cli_" + std::to_string(::getpid()));
  std::vector<cv::Vec3d> truth;
  void SetUp() override {
    std::filesystem::create_directories(dir);
    const StereoRig rig = thesis_stereo_rig();
    save_calibration(rectify(rig), (dir / "calib.yaml").string());
    cv::RNG rng(61);
    std::ofstream csv(dir / "pairs.csv");
    csv << "left,right\n";
    for (int i = 0; i < 6; ++i) {
      const auto scene = testing::random_star_scene(rig, rng, testing::StarSceneRanges{});
      ASSERT_TRUE(scene);
      const std::string l = "left" + std::to_string(i) + ".png", r = "right" + std::to_string(i) + ".png";
      cv::imwrite((dir / l).string(), scene->left);
      cv::imwrite((dir / r).string(), scene->right);
      csv << l << "," << r << "\n";
      truth.push_back(scene->truth_left);
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir); }

  // Runs the executable; returns the exit code, stdout and stderr in `out`, `err`.
  int run(const std::string& args, std::string& out, std::string& err) {
    const std::string o = (dir / "stdout.txt").string(), e = (dir / "stderr.txt").string();
    const int status = std::system((std::string(VISION_STATION_EXE) + " " + args + " >" + o + " 2>" + e).c_str());
    auto slurp = [](const std::string& p) {
      std::ifstream in(p);
      return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    };
    out = slurp(o);
    err = slurp(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string path(const std::string& name) const { return (dir / name).string(); }
};

double json_number(const std::string& line, const std::string& key) {
  const size_t at = line.find("\"" + key + "\":");
  return at == std::string::npos ? NAN : std::stod(line.substr(at + key.size() + 3));
}

TEST_F(CommandLineTest, DetectPrintsOneAccurateJsonLinePerPair) {
  std::string out, err;
  ASSERT_EQ(run("detect --calib " + path("calib.yaml") + " --pairs " + path("pairs.csv"), out, err), 0) << err;
  std::istringstream lines(out);
  std::string line;
  size_t i = 0;
  for (; std::getline(lines, line); ++i) {
    ASSERT_LT(i, truth.size());
    ASSERT_NE(line.find("\"found\":true"), std::string::npos) << line;
    const cv::Vec3d p(json_number(line, "x"), json_number(line, "y"), json_number(line, "z"));
    EXPECT_LT(cv::norm(p - truth[i]), 0.02 * cv::norm(truth[i])) << line;
  }
  EXPECT_EQ(i, truth.size());

  ASSERT_EQ(run("detect --calib " + path("calib.yaml") + " --left " + path("left0.png") + " --right " +
                    path("right0.png"), out, err), 0) << err;
  EXPECT_EQ(out.rfind("{\"found\":true", 0), 0u) << out;
}

TEST_F(CommandLineTest, DetectNamesBadInput) {
  std::string out, err;
  EXPECT_EQ(run("detect --calib " + path("calib.yaml") + " --left " + path("absent.png") + " --right " +
                    path("right0.png"), out, err), 1);
  EXPECT_NE(err.find("absent.png: cannot read image"), std::string::npos) << err;

  cv::imwrite(path("small.png"), cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)));
  EXPECT_EQ(run("detect --calib " + path("calib.yaml") + " --left " + path("small.png") + " --right " +
                    path("right0.png"), out, err), 1);
  EXPECT_NE(err.find("640x480 but the calibration is for 728x488"), std::string::npos) << err;

  {
    cv::FileStorage fs(path("partial.yaml"), cv::FileStorage::WRITE);
    fs << "image_width" << 728 << "image_height" << 488;
  }
  EXPECT_EQ(run("detect --calib " + path("partial.yaml") + " --pairs " + path("pairs.csv"), out, err), 1);
  EXPECT_NE(err.find("missing key 'K1'"), std::string::npos) << err;

  EXPECT_EQ(run("detect --calib " + path("calib.yaml"), out, err), 2);
  EXPECT_NE(err.find("missing --left"), std::string::npos) << err;
}

TEST_F(CommandLineTest, RunOnFilesReportsStatusAndFixes) {
  std::string out, err;
  ASSERT_EQ(run("run --calib " + path("calib.yaml") + " --source files:" + dir.string() + " --status-s 0", out, err), 0)
      << err;
  EXPECT_NE(err.find("fps, detection 100 %"), std::string::npos) << err;
  EXPECT_NE(err.find("total: 6 frames, 6 fixes"), std::string::npos) << err;
}

}  // namespace
}  // namespace quad::vision
