// quad_sim end to end, for the outputs no other test makes: the PNG plots (every one docs/simulator.md
// promises, each a real picture of the flight's data), a clear failure when they cannot be made, and the
// --record MP4 (its container, video track, size and frame count). Each runs the quad_sim executable
// with the host quad_firmware on a short scenario written into the test's own folder.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace fs = std::filesystem;

namespace {

const std::string kSim = QUAD_SIM_EXE;

// Take-off after the firmware's 2 s calibration: armed at 3 s, AUTO at 3.5 s, climbing towards a point
// 1 m up and 0.36 m off the star (so the XY track has a length).
const char* kTakeOff = R"(name: app_takeoff
duration_s: 6
seed: 2
commands:
  - {at_s: 3.0, arm: true}
  - {at_s: 3.5, mode: AUTO}
  - {at_s: 3.6, setpoint_ned_m: [0.3, 0.2, -1.0], yaw_deg: 0.0}
metrics: {hold_start_s: 5.0, hold_end_s: 6.0, settle_band_m: 0.10}
)";

// On the ground, calibrating: the shortest run that still renders frames.
const char* kShort = R"(name: app_short
duration_s: 2
seed: 2
metrics: {hold_start_s: 1.0, hold_end_s: 2.0, settle_band_m: 0.10}
)";

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) / ("quad_test_app_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_file(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

int exit_code(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// quad_sim on `scenario_text` in `dir` (run folder dir/run, stderr in dir/stderr.txt), with `args`.
int quad_sim(const fs::path& dir, const char* scenario_text, const std::string& args, const std::string& env = "") {
  write_file(dir / "scenario.yaml", scenario_text);
  return exit_code(env + " '" + kSim + "' --scenario '" + (dir / "scenario.yaml").string() + "' --out '" +
                   (dir / "run").string() + "' --quiet " + args + " 2>'" + (dir / "stderr.txt").string() + "'");
}

uint32_t be32(const std::string& b, size_t at) {
  return (static_cast<uint32_t>(static_cast<uint8_t>(b[at])) << 24) |
         (static_cast<uint32_t>(static_cast<uint8_t>(b[at + 1])) << 16) |
         (static_cast<uint32_t>(static_cast<uint8_t>(b[at + 2])) << 8) | static_cast<uint32_t>(static_cast<uint8_t>(b[at + 3]));
}

// Matplotlib's default line colours (RGB) as plot_run.py uses them.
struct Colour {
  int r, g, b;
};
constexpr Colour kC0{31, 119, 180}, kC1{255, 127, 14}, kC2{44, 160, 44}, kC3{214, 39, 40};

// Pixels of a plot close to a solid line's colour.
int pixels_of_colour(const cv::Mat& bgr, Colour c) {
  int n = 0;
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      if (std::abs(p[0] - c.b) + std::abs(p[1] - c.g) + std::abs(p[2] - c.r) < 60) ++n;
    }
  return n;
}

// Pixels where green clearly dominates: the dotted C2 setpoint lines, whose dots are blended with the
// white background (no other line is greenish; blue and orange blends are not).
int greenish_pixels(const cv::Mat& bgr) {
  int n = 0;
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      if (p[1] - std::max(p[0], p[2]) > 30) ++n;
    }
  return n;
}

}  // namespace

// Every plot of docs/simulator.md "Outputs": a complete PNG (signature, IHDR, IEND) of a plausible size
// that decodes, and that shows the data series it is about in matplotlib's colours (C0 blue: the truth
// or north; C1 orange: the firmware's estimate or east; C2 green: the dotted setpoint or down; motors 2
// and 3 in C2 and C3 are drawn over 0 and 1, which fly alike). A plot whose log columns went missing or
// hold no data has no such line (plot_run.py skips absent columns, NaN draws nothing) and fails here.
// The thresholds are a third to a half of what this flight draws; without a setpoint command the
// position and attitude plots have 78 and 24 greenish pixels (their legends), with it 1040 and 339.
TEST(SimApp, WritesEveryPlotOfTheFlight) {
  const fs::path dir = fresh_dir("plots");
  ASSERT_EQ(quad_sim(dir, kTakeOff, ""), 0) << read_file(dir / "stderr.txt");
  const fs::path run = dir / "run";
  EXPECT_NE(read_file(run / "summary.json").find("\"complete\": true"), std::string::npos);
  struct Series {
    const char* what;
    std::optional<Colour> solid;  // empty: the dotted setpoint (greenish pixels)
    int min_pixels;
  };
  struct Expected {
    const char* file;
    std::vector<Series> series;
  };
  const Expected plots[] = {
      {"position.png", {{"truth", kC0, 400}, {"estimate", kC1, 400}, {"setpoint", std::nullopt, 400}}},
      {"velocity.png", {{"truth", kC0, 400}, {"estimate", kC1, 400}}},
      {"attitude.png", {{"truth", kC0, 400}, {"estimate", kC1, 400}, {"yaw setpoint", std::nullopt, 150}}},
      {"motors.png", {{"motor 2", kC2, 400}, {"motor 3", kC3, 400}}},
      {"estimate_error.png", {{"north", kC0, 200}, {"east", kC1, 200}, {"down", kC2, 200}}},
      {"track.png", {{"truth", kC0, 150}, {"estimate", kC1, 150}}},
  };
  for (const Expected& e : plots) {
    SCOPED_TRACE(e.file);
    const std::string png = read_file(run / e.file);
    ASSERT_GT(png.size(), 20000u) << "missing or nearly empty";
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << "PNG signature";
    EXPECT_EQ(png.substr(12, 4), "IHDR");
    EXPECT_EQ(png.substr(png.size() - 8, 4), "IEND") << "the file ends with its IEND chunk (not cut off)";
    const uint32_t width = be32(png, 16), height = be32(png, 20);
    EXPECT_GE(width, 500u);
    EXPECT_GE(height, 300u);
    const cv::Mat image = cv::imread((run / e.file).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty()) << "does not decode";
    EXPECT_EQ(static_cast<uint32_t>(image.cols), width);
    for (const Series& series : e.series) {
      const int n = series.solid ? pixels_of_colour(image, *series.solid) : greenish_pixels(image);
      EXPECT_GT(n, series.min_pixels) << series.what << " is not drawn (" << n << " pixels of its colour)";
    }
  }
  fs::remove_all(dir);
}

// When the plots cannot be made (here python3 finds a matplotlib that fails to import) quad_sim says so
// and exits with 3, and the run's log and complete summary are still there.
TEST(SimApp, APlottingFailureIsAnErrorThatKeepsTheLogAndSummary) {
  const fs::path dir = fresh_dir("plotfail");
  fs::create_directories(dir / "py" / "matplotlib");
  write_file(dir / "py" / "matplotlib" / "__init__.py", "raise ImportError('matplotlib broken on purpose (test)')\n");
  const int rc = quad_sim(dir, kShort, "", "env PYTHONPATH='" + (dir / "py").string() + "'");
  const std::string err = read_file(dir / "stderr.txt");
  EXPECT_EQ(rc, 3) << err;
  EXPECT_NE(err.find("plotting failed"), std::string::npos) << err;
  EXPECT_NE(err.find("broken on purpose"), std::string::npos) << "python's own message reaches the user";
  EXPECT_NE(read_file(dir / "run" / "summary.json").find("\"complete\": true"), std::string::npos);
  const std::string log = read_file(dir / "run" / "log.csv");
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 201) << "header and 200 rows (2 s at 100 Hz)";
  EXPECT_FALSE(fs::exists(dir / "run" / "position.png"));
  // --no-plots does not try, so it does not fail.
  fs::remove_all(dir / "run");
  EXPECT_EQ(quad_sim(dir, kShort, "--no-plots", "env PYTHONPATH='" + (dir / "py").string() + "'"), 0)
      << read_file(dir / "stderr.txt");
  fs::remove_all(dir);
}

namespace {

// The boxes of an ISO base media file (MP4): size (32-bit, 1 = 64-bit follows, 0 = to the end), type.
struct Box {
  std::string type;
  size_t payload = 0, end = 0;
};

std::vector<Box> boxes(const std::string& b, size_t from, size_t to) {
  std::vector<Box> out;
  while (from + 8 <= to) {
    uint64_t size = be32(b, from);
    size_t header = 8;
    if (size == 1 && from + 16 <= to) {
      size = (static_cast<uint64_t>(be32(b, from + 8)) << 32) | be32(b, from + 12);
      header = 16;
    } else if (size == 0) {
      size = to - from;
    }
    if (size < header || from + size > to) break;  // malformed: stop
    out.push_back({b.substr(from + 4, 4), from + header, from + static_cast<size_t>(size)});
    from += static_cast<size_t>(size);
  }
  return out;
}

std::optional<Box> child(const std::string& b, const Box& parent, const std::string& type, size_t skip = 0) {
  for (const Box& c : boxes(b, parent.payload + skip, parent.end))
    if (c.type == type) return c;
  return std::nullopt;
}

}  // namespace

// --record renders the chase camera into an H.264 MP4 at 30 frames per simulated second, 640 x 360: the
// file is a well-formed MP4 (ftyp first, a movie box and the media data), with one video track of that
// size whose sample table holds one frame per 1/30 s of the flight; ffprobe, when installed (ffmpeg
// package), reads the same.
TEST(SimApp, RecordsTheFlightAsAnMp4) {
  const fs::path dir = fresh_dir("record");
  const fs::path mp4 = dir / "flight.mp4";
  // Leak detection off for this run only, as test_sim_viewer does for its GL runs: Mesa's software
  // renderer leaks a few bytes per context in code LeakSanitizer cannot name (sanitizer builds).
  ASSERT_EQ(quad_sim(dir, kShort, "--no-plots --record '" + mp4.string() + "'", "env ASAN_OPTIONS=detect_leaks=0"), 0)
      << read_file(dir / "stderr.txt");
  const std::string b = read_file(mp4);
  ASSERT_GT(b.size(), 5000u) << "no video at " << mp4;
  const std::vector<Box> top = boxes(b, 0, b.size());
  ASSERT_FALSE(top.empty());
  EXPECT_EQ(top.front().type, "ftyp");
  const std::string brand = b.substr(top.front().payload, 4);
  EXPECT_TRUE(brand == "isom" || brand == "mp42" || brand == "iso5") << "major brand " << brand;
  std::optional<Box> moov, mdat;
  size_t covered = 0;
  for (const Box& x : top) {
    if (x.type == "moov") moov = x;
    if (x.type == "mdat") mdat = x;
    covered = x.end;
  }
  EXPECT_EQ(covered, b.size()) << "the boxes cover the whole file";
  ASSERT_TRUE(moov) << "no movie box: ffmpeg did not finish the file";
  ASSERT_TRUE(mdat);
  EXPECT_GT(mdat->end - mdat->payload, 2000u);

  std::optional<Box> video;
  for (const Box& trak : boxes(b, moov->payload, moov->end)) {
    if (trak.type != "trak") continue;
    const auto mdia = child(b, trak, "mdia");
    const auto hdlr = mdia ? child(b, *mdia, "hdlr") : std::nullopt;
    if (hdlr && b.substr(hdlr->payload + 8, 4) == "vide") video = trak;
  }
  ASSERT_TRUE(video) << "no video track";
  const auto tkhd = child(b, *video, "tkhd");
  ASSERT_TRUE(tkhd);
  // The track header ends with width and height, 16.16 fixed point.
  const uint32_t width = be32(b, tkhd->end - 8) >> 16, height = be32(b, tkhd->end - 4) >> 16;
  EXPECT_EQ(width, 640u);
  EXPECT_EQ(height, 360u);
  const auto mdia = child(b, *video, "mdia");
  const auto minf = child(b, *mdia, "minf");
  ASSERT_TRUE(minf);
  const auto stbl = child(b, *minf, "stbl");
  ASSERT_TRUE(stbl);
  const auto stsd = child(b, *stbl, "stsd");
  ASSERT_TRUE(stsd);
  EXPECT_NE(b.substr(stsd->payload, stsd->end - stsd->payload).find("avc1"), std::string::npos) << "H.264";
  const auto stsz = child(b, *stbl, "stsz");
  ASSERT_TRUE(stsz);
  const uint32_t frames = be32(b, stsz->payload + 8);  // version/flags, sample size, sample count
  std::printf("--record: %u frames of %u x %u for 2 s of flight, %zu bytes\n", frames, width, height, b.size());
  EXPECT_GE(frames, 59u) << "30 frames per simulated second";
  EXPECT_LE(frames, 61u);

  if (exit_code("command -v ffprobe >/dev/null 2>&1") == 0) {
    const fs::path probe = dir / "probe.txt";
    ASSERT_EQ(exit_code("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                        "stream=codec_name,width,height,nb_read_frames -of default=noprint_wrappers=1 '" +
                        mp4.string() + "' > '" + probe.string() + "'"),
              0);
    const std::string p = read_file(probe);
    EXPECT_NE(p.find("codec_name=h264"), std::string::npos) << p;
    EXPECT_NE(p.find("width=640"), std::string::npos) << p;
    EXPECT_NE(p.find("height=360"), std::string::npos) << p;
    EXPECT_NE(p.find("nb_read_frames=" + std::to_string(frames)), std::string::npos) << p;
  }
  fs::remove_all(dir);
}
