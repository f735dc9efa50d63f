// quad_sim --viewer end to end: without a display it refuses before the flight; under a virtual X server
// (xvfb-run) it draws the flight (checked on its screenshot) and closing the window ends the run the way
// Ctrl-C does.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "x_display.h"

namespace fs = std::filesystem;

namespace {

const std::string kSim = QUAD_SIM_EXE;
const std::string kShort = QUAD_SIM_TEST_DIR "/viewer_short.yaml";  // 7 s take-off

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("quad_test_viewer_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

using quad_test::exit_code;
using quad_test::have_xvfb;
using quad_test::read_text;

// Runs a command on a virtual X server. Leak detection is off for these runs only: Mesa's software GL
// driver is dlopen()ed, leaks a few bytes per context and is unloaded before LeakSanitizer reports, so
// its frames cannot be named in a suppression. Every other quad_sim run in the suite keeps it on.
const std::string kXvfb = quad_test::xvfb_run("1280x720x24", "ASAN_OPTIONS=detect_leaks=0");

}  // namespace

TEST(SimViewer, WithoutDisplayFailsBeforeTheFlight) {
  const fs::path dir = fresh_dir("nodisplay");
  const fs::path run = dir / "run";
  const std::string cmd = "env -u DISPLAY -u WAYLAND_DISPLAY '" + kSim + "' --scenario '" + kShort +
                          "' --viewer --no-plots --quiet --out '" + run.string() + "' 2>'" +
                          (dir / "stderr.txt").string() + "'";
  EXPECT_NE(exit_code(cmd), 0);
  EXPECT_NE(read_text(dir / "stderr.txt").find("--viewer needs a display"), std::string::npos)
      << read_text(dir / "stderr.txt");
  EXPECT_FALSE(fs::exists(run)) << "the flight started although the window could not open";
  fs::remove_all(dir);
}

TEST(SimViewer, DrawsTheFlightUnderXvfb) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/packages-debian.txt: xvfb)";
  const fs::path dir = fresh_dir("draw");
  const fs::path run = dir / "run", shot = dir / "shot.png";
  const std::string cmd = kXvfb + "'" + kSim + "' --scenario '" + kShort +
                          "' --viewer --viewer-screenshot '" + shot.string() + "' --no-plots --quiet --out '" +
                          run.string() + "' 2>'" + (dir / "stderr.txt").string() + "'";
  ASSERT_EQ(exit_code(cmd), 0) << read_text(dir / "stderr.txt");
  const std::string summary = read_text(run / "summary.json");
  EXPECT_NE(summary.find("\"complete\": true"), std::string::npos) << summary.substr(0, 300);

  const cv::Mat bgr = cv::imread(shot.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(bgr.empty()) << "no screenshot at " << shot;
  EXPECT_EQ(bgr.cols, 960);
  EXPECT_EQ(bgr.rows, 540);
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  // The tracking camera keeps the vehicle (a near-black body) in the middle of the picture...
  double centre_min = 0.0;
  cv::minMaxLoc(gray(cv::Rect(gray.cols / 2 - 40, gray.rows / 2 - 40, 80, 80)), &centre_min);
  EXPECT_LT(centre_min, 40.0) << "no vehicle at the centre of the view";
  // ...over the lit floor, which fills the lower half (a blank or unlit picture has none of it).
  const double floor_mean = cv::mean(gray(cv::Rect(0, gray.rows / 2, gray.cols, gray.rows / 2)))[0];
  EXPECT_GT(floor_mean, 80.0) << "no floor in the lower half of the view";
  fs::remove_all(dir);
}

TEST(SimViewer, ClosingTheWindowEndsTheRunLikeCtrlC) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/packages-debian.txt: xvfb)";
  const fs::path dir = fresh_dir("close");
  const fs::path run = dir / "run";
  // The full 60 s hover; once the log holds 3 s of flight (100 Hz rows) the helper closes the window, as a
  // user would.
  const std::string log_csv = (run / "log.csv").string();
  const std::string inner = "'" + kSim + "' --scenario '" QUAD_SIM_SOURCE_DIR "/scenarios/hover.yaml' --viewer "
                            "--no-plots --quiet --out '" + run.string() + "' 2>'" + (dir / "stderr.txt").string() +
                            "' & pid=$!; n=0; while [ $(cat '" + log_csv + "' 2>/dev/null | wc -l) -lt 300 ] && "
                            "[ $n -lt 1200 ]; do sleep 0.05; n=$((n+1)); done; '" QUAD_X11_CLOSE_WINDOW
                            "' 'quad_sim: hover' 30 || exit 97; wait $pid";
  std::string quoted;  // inner goes through sh -c '...'
  for (char c : inner) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  const int rc = exit_code(kXvfb + "sh -c '" + quoted + "'");
  ASSERT_NE(rc, 97) << "the viewer window never appeared";
  EXPECT_EQ(rc, 1) << read_text(dir / "stderr.txt");  // cut short, like Ctrl-C
  const std::string summary = read_text(run / "summary.json");
  EXPECT_NE(summary.find("\"complete\": false"), std::string::npos) << summary.substr(0, 300);
  EXPECT_NE(summary.find("\"cut_short\": \"interrupted\""), std::string::npos) << summary.substr(0, 300);
  // Nothing lost: the log holds the rows up to the stop, which came in the middle of the flight.
  const std::string log = read_text(run / "log.csv");
  EXPECT_GE(std::count(log.begin(), log.end(), '\n'), 300) << "rows of the cut-short run are missing";
  const size_t at = summary.find("\"sim_time_s\": ");
  ASSERT_NE(at, std::string::npos);
  const double sim_time_s = std::stod(summary.substr(at + 14));
  EXPECT_GE(sim_time_s, 3.0);
  EXPECT_LT(sim_time_s, 60.0) << "the run went on after the window was closed";
  fs::remove_all(dir);
}
