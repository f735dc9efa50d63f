// Simulator speed (Google Benchmark; not a test): lockstep with the host
// firmware, 1 kHz physics, 100 Hz control, no rendering, as a real-time factor (counter "rtf").
//
//   build/<tree>/tests/bench_sim --benchmark_filter=Lockstep
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <string>

#include "quad/sim/ground_camera.h"
#include "quad/sim/hil_session.h"
#include "quad/sim/imu.h"
#include "quad/sim/scenario.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {

void lockstep(benchmark::State& state, const std::string& firmware) {
  if (access(firmware.c_str(), X_OK) != 0) {
    state.SkipWithError(("not built: " + firmware).c_str());
    return;
  }
  Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/hover.yaml");
  double sim = 0.0, wall = 0.0;
  for (auto _ : state) {
    SessionOptions o;
    o.out_dir = std::string(P_tmpdir) + "/quad_sim_bench_" + std::to_string(getpid());
    o.firmware_argv = {firmware};
    o.progress = false;
    const SessionResult r = run_session(s, o);
    if (!r.complete) state.SkipWithError(r.reason.c_str());
    sim += r.sim_time_s;
    wall += r.wall_time_s;
  }
  state.counters["rtf"] = sim / wall;  // simulated seconds per wall-clock second
  state.counters["sim_s"] = sim;
}

void BM_LockstepHoverWithFirmware(benchmark::State& state) { lockstep(state, QUAD_SIM_FIRMWARE); }

// The whole closed loop of `make flight` (rendered cameras, vision station process, firmware).
void BM_LockstepFlightWithStation(benchmark::State& state) {
  if (access(QUAD_SIM_FIRMWARE, X_OK) != 0 || access(QUAD_VISION_STATION, X_OK) != 0) {
    state.SkipWithError("quad_firmware or vision_station not built");
    return;
  }
  Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/flight.yaml");
  double sim = 0.0, wall = 0.0;
  for (auto _ : state) {
    SessionOptions o;
    o.out_dir = std::string(P_tmpdir) + "/quad_sim_bench_flight_" + std::to_string(getpid());
    o.firmware_argv = {QUAD_SIM_FIRMWARE};
    o.station_argv = {QUAD_VISION_STATION, "run"};
    o.progress = false;
    const SessionResult r = run_session(s, o);
    if (!r.complete) state.SkipWithError(r.reason.c_str());
    sim += r.sim_time_s;
    wall += r.wall_time_s;
  }
  state.counters["rtf"] = sim / wall;
  state.counters["sim_s"] = sim;
}
BENCHMARK(BM_LockstepFlightWithStation)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// One rendered 728 x 488 stereo pair at 1.5 m (both views, noise, exposure, vignetting); arg 1: with the
// floor photograph and interlaced fields of flight.yaml's realistic camera, side by side.
void BM_RenderStereoPair(benchmark::State& state) {
  CameraParams params;
  if (state.range(0) == 1) {
    params.floor_texture = "/usr/share/doc/opencv-doc/examples/data/baboon.jpg";
    params.interlaced = true;
  }
  VehicleParams vp;
  vp.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle vehicle(vp);
  const SimStereoRig rig = stereo_rig_from_model(vehicle.model(), params, vp.model_path);
  StereoCameraRenderer renderer(params, rig, make_floor_scene(params, Rng(1, "floor")), Rng(1, "camera"));
  cv::Mat left, right;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX()));
  for (auto _ : state) {
    renderer.render(Eigen::Vector3d(0.02, -0.01, -1.5), q, false, left, right);
    benchmark::DoNotOptimize(left.data);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderStereoPair)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// One frame set of the room cameras (seed 003 table 6.1: two 1024 x 768 colour views) seeing
// `range(0)` vehicles 0.6 m apart at 1 m, with light, colour cast and noise.
void BM_RenderGroundCameras(benchmark::State& state) {
  GroundCameraParams params;
  GroundCameraRenderer renderer(params, ground_cameras_from(params), Rng(1, "ground_cameras"));
  std::vector<MarkedVehicle> vehicles;
  for (int i = 0; i < state.range(0); ++i) {
    MarkedVehicle v;
    v.id = i + 1;
    v.p_ned = Eigen::Vector3d(0.6 * (i % 2) - 0.3, 0.6 * (i / 2) - 0.3, -1.0);
    v.markers_frd = params.markers_frd;
    vehicles.push_back(v);
  }
  cv::Mat image;
  double t = 0.0;
  for (auto _ : state) {
    for (size_t k = 0; k < renderer.cameras().size(); ++k) renderer.render(k, vehicles, t, image);
    t += 1.0 / 30.0;
    benchmark::DoNotOptimize(image.data);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderGroundCameras)->Arg(1)->Arg(4)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LockstepHoverWithFirmware)->Unit(benchmark::kSecond)->Iterations(3)->UseRealTime();

// The same loop against the stand-in firmware (answers at once): the simulator's own share.
void BM_LockstepHoverWithStandIn(benchmark::State& state) { lockstep(state, QUAD_SIM_FAKE_FIRMWARE); }
BENCHMARK(BM_LockstepHoverWithStandIn)->Unit(benchmark::kSecond)->Iterations(3)->UseRealTime();

// One physics step with the motor models and the IMU sample (the 1 kHz inner loop).
void BM_PhysicsStepWithImu(benchmark::State& state) {
  VehicleParams p;
  p.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle v(p);
  v.reset({0.0, 0.0}, 2.0, 0.0);
  v.set_commands({0.63, 0.63, 0.63, 0.63});
  v.settle_motors();
  Mpu6000 imu(ImuParams{}, Rng(1, "imu"));
  for (auto _ : state) {
    v.step();
    const VehicleTruth t = v.truth();
    benchmark::DoNotOptimize(imu.sample(t.specific_force_frd, t.rate_frd, v.mean_speed_fraction()));
    if (v.time() > 5.0) v.reset({0.0, 0.0}, 2.0, 0.0), v.settle_motors();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PhysicsStepWithImu);

}  // namespace
}  // namespace quad::sim

BENCHMARK_MAIN();
