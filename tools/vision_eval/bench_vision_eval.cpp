// Speed and detection of the vision station on a generated evaluation set, side by side in one run with
// the thesis pipeline and a fixed plain-OpenCV baseline (the 50-line recipe, in C++):
// adaptiveThreshold MEAN_C on the inverted image (block 151, C −40), one 3 × 3 opening, external contours
// of at least 150 px², their points undistorted and rectified, approxPolyDP (2 % of the perimeter) with
// 8 ± 1 vertices, matchShapes I1 ≤ 0.08 against the ideal star, the best match per image; the two best
// matches give a fix when their rectified rows agree within 2.5 px (the station's own gate).
//   bench_vision_eval --sets DIR --calib calib.yaml [--settings S.yaml] [benchmark flags]
// (--settings adds BM_Station/settings_file: the station with that settings file.)
// DIR/<condition>/{pairs.csv,truth.csv} as written by vision_eval_gen; all pairs are decoded before
// timing. Counters: found (stars in full view located within 5 % of range / stars in view), false_fixes,
// and after the run a summary with each method's rates and its time relative to the baseline.
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/ideal_star.h"
#include "quad/vision/settings_file.h"
#include "quad/vision/stereo_locator.h"

namespace {

using namespace quad::vision;
namespace fs = std::filesystem;

struct EvalPair {
  cv::Mat left, right;
  bool star = false;
  cv::Vec3d truth;
  double range = 0.0;
};

struct EvalSet {
  StereoCalibration calibration;
  std::vector<EvalPair> pairs;
  size_t stars = 0;
};

std::string g_sets, g_calib, g_settings;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  return cells;
}

const EvalSet& eval_set() {
  static const EvalSet set = [] {
    EvalSet s;
    s.calibration = load_calibration(g_calib);
    for (const fs::directory_entry& dir : fs::directory_iterator(g_sets)) {
      std::ifstream pairs(dir.path() / "pairs.csv"), truth(dir.path() / "truth.csv");
      if (!pairs || !truth) continue;
      std::string p, t;
      std::getline(pairs, p);
      std::getline(truth, t);
      while (std::getline(pairs, p) && std::getline(truth, t)) {
        const std::vector<std::string> names = split(p), cells = split(t);
        if (names.size() < 2 || cells.size() < 7) throw std::runtime_error((dir.path() / "truth.csv").string() + ": bad line");
        EvalPair e;
        e.left = cv::imread((dir.path() / names[0]).string(), cv::IMREAD_GRAYSCALE);
        e.right = cv::imread((dir.path() / names[1]).string(), cv::IMREAD_GRAYSCALE);
        if (e.left.empty() || e.right.empty()) throw std::runtime_error((dir.path() / names[0]).string() + ": unreadable");
        e.star = cells[1] == "1";
        e.truth = cv::Vec3d(std::stod(cells[3]), std::stod(cells[4]), std::stod(cells[5]));
        e.range = std::stod(cells[6]);
        s.stars += e.star ? 1 : 0;
        s.pairs.push_back(std::move(e));
      }
    }
    if (s.pairs.empty()) throw std::runtime_error(g_sets + ": no pairs.csv/truth.csv under it");
    return s;
  }();
  return set;
}

// The fixed plain-OpenCV baseline for one image: the rectified centroid of the best star match.
class OpenCvBaseline {
 public:
  OpenCvBaseline(const StereoCalibration& c, int camera)
      : K_(camera == 0 ? c.rig.left.K : c.rig.right.K), D_(camera == 0 ? c.rig.left.D : c.rig.right.D),
        R_(camera == 0 ? c.R1 : c.R2), P_(camera == 0 ? c.P1 : c.P2), ideal_(ideal_star_contour(0.4)) {}

  bool best(const cv::Mat& gray, cv::Point2d& centroid) {
    cv::bitwise_not(gray, inverted_);
    cv::adaptiveThreshold(inverted_, binary_, 255, cv::ADAPTIVE_THRESH_MEAN_C, cv::THRESH_BINARY, 151, -40);
    cv::morphologyEx(binary_, binary_, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
    cv::findContours(binary_, contours_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    double best_score = 0.08;
    bool found = false;
    for (const std::vector<cv::Point>& contour : contours_) {
      if (cv::contourArea(contour) < 150.0) continue;
      std::vector<cv::Point2f> raw(contour.begin(), contour.end()), rect, poly;
      cv::undistortPoints(raw, rect, K_, D_, R_, P_);
      cv::approxPolyDP(rect, poly, 0.02 * cv::arcLength(rect, true), true);
      if (poly.size() < 7 || poly.size() > 9) continue;
      const double score = cv::matchShapes(rect, ideal_, cv::CONTOURS_MATCH_I1, 0.0);
      if (score > best_score) continue;
      best_score = score;
      const cv::Moments m = cv::moments(rect);
      centroid = cv::Point2d(m.m10 / m.m00, m.m01 / m.m00);
      found = true;
    }
    return found;
  }

 private:
  cv::Matx33d K_;
  cv::Vec<double, 5> D_;
  cv::Matx33d R_;
  cv::Matx34d P_;
  std::vector<cv::Point> ideal_;
  cv::Mat inverted_, binary_;
  std::vector<std::vector<cv::Point>> contours_;
};

struct Outcome {
  size_t found = 0, false_fixes = 0, pairs = 0;
  std::vector<double> pair_cpu_us;  // each pair's CPU time
};

// This thread's CPU time, microseconds: a pair's own cost, without time spent waiting for the core.
double thread_cpu_us() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e6 + t.tv_nsec * 1e-3;
}

void score(const EvalPair& pair, bool fixed, const cv::Vec3d& p, Outcome& o) {
  ++o.pairs;
  if (!fixed) return;
  if (pair.star && cv::norm(p - pair.truth) <= 0.05 * pair.range) {
    ++o.found;
  } else {
    ++o.false_fixes;
  }
}

void report(benchmark::State& state, const Outcome& o) {
  const EvalSet& set = eval_set();
  const double rounds = static_cast<double>(o.pairs) / set.pairs.size();
  state.counters["found"] = o.found / (rounds * set.stars);
  state.counters["false_fixes"] = o.false_fixes / rounds;
  state.counters["pairs"] = static_cast<double>(set.pairs.size());
  // The median pair (the figure): pairs without a star cost far less than pairs with one, so
  // the mean per pair is lower than the median.
  std::vector<double> cpu = o.pair_cpu_us;
  if (!cpu.empty()) {
    std::nth_element(cpu.begin(), cpu.begin() + cpu.size() / 2, cpu.end());
    state.counters["median_pair_cpu_us"] = cpu[cpu.size() / 2];
  }
}

void BM_Station(benchmark::State& state, LocatorSettings settings) {
  cv::setNumThreads(1);
  const EvalSet& set = eval_set();
  settings.track_roi = false;
  StereoStarLocator locator(set.calibration, settings);
  locator.locate(set.pairs[0].left, set.pairs[0].right);  // builds the rectification tables (once per run)
  Outcome o;
  StageTimes sum;
  size_t i = 0;
  for (auto _ : state) {
    const EvalPair& pair = set.pairs[i++ % set.pairs.size()];
    const double t0 = thread_cpu_us();
    const StarFix fix = locator.locate(pair.left, pair.right);
    o.pair_cpu_us.push_back(thread_cpu_us() - t0);
    benchmark::DoNotOptimize(fix.p_left);
    score(pair, fix.found, fix.p_left, o);
    sum.threshold_morphology_us += fix.times.threshold_morphology_us;
    sum.contours_filters_us += fix.times.contours_filters_us;
    sum.rectify_points_us += fix.times.rectify_points_us;
    sum.pose_us += fix.times.pose_us;
  }
  report(state, o);
  state.counters["threshold_us"] = sum.threshold_morphology_us / o.pairs;
  state.counters["contours_us"] = sum.contours_filters_us / o.pairs;
  state.counters["rectify_refine_us"] = sum.rectify_points_us / o.pairs;
  state.counters["pose_us"] = sum.pose_us / o.pairs;
}

void BM_OpenCvBaseline(benchmark::State& state) {
  cv::setNumThreads(1);
  const EvalSet& set = eval_set();
  const StereoCalibration& c = set.calibration;
  OpenCvBaseline left(c, 0), right(c, 1);
  const double f = c.P1(0, 0), cx1 = c.P1(0, 2), cy = c.P1(1, 2), cx2 = c.P2(0, 2), b = c.baseline();
  Outcome o;
  size_t i = 0;
  for (auto _ : state) {
    const EvalPair& pair = set.pairs[i++ % set.pairs.size()];
    cv::Point2d l, r;
    const double t0 = thread_cpu_us();
    const bool both = left.best(pair.left, l) && right.best(pair.right, r);
    o.pair_cpu_us.push_back(thread_cpu_us() - t0);
    const double d = (l.x - cx1) - (r.x - cx2);
    cv::Vec3d p;
    const bool fixed = both && std::fabs(l.y - r.y) <= 2.5 && d > 0.0;
    if (fixed) {
      const double z = f * b / d;  // thesis eq. 8.3/8.4 in the rectified frame, then back to the left camera
      p = c.R1.t() * cv::Vec3d((l.x - cx1) * z / f, (l.y - cy) * z / f, z);
    }
    score(pair, fixed, p, o);
  }
  report(state, o);
}

// Collects each benchmark's mean time per pair for the summary.
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      if (run.run_type != Run::RT_Aggregate || run.aggregate_name != "median") continue;
      Entry& e = entries[run.run_name.function_name];
      e.us = run.GetAdjustedRealTime();
      e.cpu_us = run.GetAdjustedCPUTime();
      e.found = run.counters.count("found") ? static_cast<double>(run.counters.at("found")) : 0.0;
      e.false_fixes = run.counters.count("false_fixes") ? static_cast<double>(run.counters.at("false_fixes")) : 0.0;
      e.median_pair_cpu_us =
          run.counters.count("median_pair_cpu_us") ? static_cast<double>(run.counters.at("median_pair_cpu_us")) : 0.0;
    }
  }
  struct Entry {
    double us = 0.0, cpu_us = 0.0, found = 0.0, false_fixes = 0.0, median_pair_cpu_us = 0.0;
  };
  std::map<std::string, Entry> entries;
};

}  // namespace

// Registered once the set is loaded: each repetition is one pass over every pair.
void register_benchmarks(int64_t pairs) {
  const auto station = [](DetectorMethod m, Deinterlace d) {
    LocatorSettings settings;
    settings.detector.method = m;
    settings.detector.deinterlace = d;
    return [settings](benchmark::State& state) { BM_Station(state, settings); };
  };
  std::vector<benchmark::internal::Benchmark*> all{
      benchmark::RegisterBenchmark("BM_Station/robust_field", station(DetectorMethod::kRobust, Deinterlace::kField)),
      benchmark::RegisterBenchmark("BM_Station/robust_blend", station(DetectorMethod::kRobust, Deinterlace::kBlend)),
      benchmark::RegisterBenchmark("BM_Station/robust_none", station(DetectorMethod::kRobust, Deinterlace::kNone)),
      benchmark::RegisterBenchmark("BM_Station/thesis_none", station(DetectorMethod::kThesis, Deinterlace::kNone)),
      benchmark::RegisterBenchmark("BM_OpenCvBaseline", BM_OpenCvBaseline)};
  if (!g_settings.empty()) {  // one more configuration, from a station settings file
    const LocatorSettings settings = load_station_settings(g_settings).locator;
    all.push_back(benchmark::RegisterBenchmark("BM_Station/settings_file",
                                               [settings](benchmark::State& state) { BM_Station(state, settings); }));
  }
  for (benchmark::internal::Benchmark* b : all) {
    b->Unit(benchmark::kMicrosecond)->Iterations(pairs)->Repetitions(3)->ReportAggregatesOnly(true);
  }
}

int main(int argc, char** argv) {
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--sets" || a == "--calib" || a == "--settings") && i + 1 < argc) {
      (a == "--sets" ? g_sets : a == "--calib" ? g_calib : g_settings) = argv[++i];
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (g_sets.empty() || g_calib.empty()) {
    std::fprintf(stderr, "usage: bench_vision_eval --sets DIR --calib calib.yaml [--settings S.yaml] [benchmark flags]\n");
    return 2;
  }
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  try {
    std::fprintf(stderr, "%zu pairs, %zu stars in full view\n", eval_set().pairs.size(), eval_set().stars);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_vision_eval: %s\n", e.what());
    return 1;
  }
  try {
    register_benchmarks(static_cast<int64_t>(eval_set().pairs.size()));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_vision_eval: %s\n", e.what());
    return 1;
  }
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const auto base = reporter.entries.find("BM_OpenCvBaseline");
  std::printf("\nsummary (median of the repetitions, per stereo pair):\n");
  // CPU time is reported beside wall time: on a shared machine the wall time includes waiting for the core.
  std::printf("| method | found | false fixes per pass | wall µs per pair | CPU µs per pair | CPU time / OpenCV baseline | median pair CPU µs |\n"
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  for (const auto& [name, e] : reporter.entries) {
    const double ratio = base != reporter.entries.end() && base->second.cpu_us > 0 ? e.cpu_us / base->second.cpu_us : 0.0;
    std::printf("| %s | %.2f %% | %.0f | %.0f | %.0f | %.2f | %.0f |\n", name.c_str(), 100.0 * e.found, e.false_fixes, e.us,
                e.cpu_us, ratio, e.median_pair_cpu_us);
  }
  benchmark::Shutdown();
  return 0;
}
