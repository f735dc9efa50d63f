// Speed of the vision station: one 728 × 488 greyscale stereo pair from raw frames to the fix,
// on one core, full-frame search and ROI tracking; per-stage split reported as counters (µs per pair).
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "quad/vision/stereo_locator.h"
#include "star_scenes.h"

namespace {

using namespace quad::vision;

struct Fixture {
  StereoRig rig = thesis_stereo_rig();
  StereoCalibration calibration = rectify(rig);
  std::vector<testing::StarScene> scenes;
  Fixture() {
    cv::setNumThreads(1);  // one core
    cv::RNG rng(4242);
    testing::StarSceneRanges ranges;
    ranges.min_height = 1.0;  // the hover band of the flight scenario (1.5 m) and around it
    ranges.max_height = 2.6;
    while (scenes.size() < 16) {
      if (auto scene = testing::random_star_scene(rig, rng, ranges)) scenes.push_back(std::move(*scene));
    }
  }
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

void run(benchmark::State& state, bool track) {
  const Fixture& f = fixture();
  LocatorSettings settings;
  settings.track_roi = track;
  StereoStarLocator locator(f.calibration, settings);
  StageTimes sum;
  size_t i = 0, found = 0, frames = 0;
  for (auto _ : state) {
    // Tracking sees the same scene repeatedly (a hovering vehicle); full-frame cycles through scenes.
    const testing::StarScene& scene = f.scenes[track ? 0 : i++ % f.scenes.size()];
    const StarFix fix = locator.locate(scene.left, scene.right);
    benchmark::DoNotOptimize(fix.p_left);
    found += fix.found ? 1 : 0;
    ++frames;
    sum.threshold_morphology_us += fix.times.threshold_morphology_us;
    sum.contours_filters_us += fix.times.contours_filters_us;
    sum.rectify_points_us += fix.times.rectify_points_us;
    sum.triangulation_us += fix.times.triangulation_us;
  }
  const double n = static_cast<double>(frames);
  state.counters["threshold_morph_us"] = sum.threshold_morphology_us / n;
  state.counters["contours_filters_us"] = sum.contours_filters_us / n;
  state.counters["rectify_points_us"] = sum.rectify_points_us / n;
  state.counters["triangulation_us"] = sum.triangulation_us / n;
  state.counters["found"] = static_cast<double>(found) / n;
}

void BM_StereoFixFullFrame(benchmark::State& state) { run(state, false); }
void BM_StereoFixTracked(benchmark::State& state) { run(state, true); }

BENCHMARK(BM_StereoFixFullFrame)->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_StereoFixTracked)->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
