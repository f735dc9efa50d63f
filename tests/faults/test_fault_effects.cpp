// The fault campaign's injection (sim/src/faults.cpp and what it drives): the combination of the
// campaign's fault types, the corrupted IMU samples, the simulated fix's errors, and the second
// star-like shape on the rendered floor, found by the vision station's own locator.
#include <gtest/gtest.h>

#include <cmath>

#include "quad/link/mavlink.h"
#include "quad/sim/faults.h"
#include "quad/sim/frames.h"
#include "quad/sim/camera_model.h"
#include "quad/sim/station_calibration.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"
#include "quad/sim/vision_fix.h"
#include "quad/vision/stereo_calibration.h"
#include "quad/vision/stereo_locator.h"

namespace quad::sim {
namespace {

namespace vis = quad::vision;

Fault fault(FaultType type, double start, double end) {
  Fault f;
  f.type = type;
  f.start_s = start;
  f.end_s = end;
  return f;
}

TEST(FaultEffects, CampaignTypesCombineInTheirWindows) {
  std::vector<Fault> faults;
  faults.push_back(fault(FaultType::kVisionLatency, 1.0, 3.0));
  faults.back().value = 0.2;
  faults.push_back(fault(FaultType::kVisionLatency, 2.0, 3.0));
  faults.back().value = 0.1;
  faults.push_back(fault(FaultType::kVisionScale, 1.0, 3.0));
  faults.back().vector = {1.0, 1.0, 1.01};
  faults.push_back(fault(FaultType::kVisionScale, 2.0, 3.0));
  faults.back().vector = {2.0, 1.0, 1.0};
  faults.push_back(fault(FaultType::kVisionDecoy, 1.5, 2.5));
  faults.back().vector = {0.5, 0.3, 0.0};
  faults.push_back(fault(FaultType::kImuSaturation, 4.0, 6.0));
  faults.push_back(fault(FaultType::kImuNonFinite, 5.0, 5.5));
  const RadioConditions radio{0.004, 0.002, 0.0, 0.0};

  const FaultEffects before = fault_effects(faults, radio, 0.5);
  EXPECT_EQ(before.vision_errors.extra_latency_s, 0.0);
  EXPECT_EQ(before.vision_errors.scale_frd, Eigen::Vector3d::Ones());
  EXPECT_FALSE(before.vision_errors.decoy_ned);
  EXPECT_EQ(before.imu, ImuSampleFault::kNone);

  const FaultEffects both = fault_effects(faults, radio, 2.2);
  EXPECT_NEAR(both.vision_errors.extra_latency_s, 0.3, 1e-12) << "vision latencies add";
  EXPECT_TRUE(both.vision_errors.scale_frd.isApprox(Eigen::Vector3d(2.0, 1.0, 1.01))) << "scales multiply";
  ASSERT_TRUE(both.vision_errors.decoy_ned);
  EXPECT_EQ(*both.vision_errors.decoy_ned, Eigen::Vector3d(0.5, 0.3, 0.0));
  EXPECT_FALSE(fault_effects(faults, radio, 2.5).vision_errors.decoy_ned) << "end is exclusive";

  EXPECT_EQ(fault_effects(faults, radio, 4.5).imu, ImuSampleFault::kSaturated);
  EXPECT_EQ(fault_effects(faults, radio, 5.2).imu, ImuSampleFault::kNonFinite) << "non-finite wins";
  EXPECT_EQ(fault_effects(faults, radio, 5.7).imu, ImuSampleFault::kSaturated);
  EXPECT_EQ(fault_effects(faults, radio, 6.0).imu, ImuSampleFault::kNone);
}

TEST(FaultEffects, ImuSamplesAsAFaultySensorReportsThem) {
  const ImuParams params;
  const ImuReading r{{0.3, -0.2, -9.8}, {0.0, -0.01, 0.02}};
  const ImuReading same = apply_imu_fault(r, ImuSampleFault::kNone, params);
  EXPECT_EQ(same.specific_force_frd, r.specific_force_frd);
  EXPECT_EQ(same.rate_frd, r.rate_frd);

  // Pinned at the ranges (8 g, 2000 deg/s) with the reading's sign; zero counts as positive.
  const ImuReading sat = apply_imu_fault(r, ImuSampleFault::kSaturated, params);
  EXPECT_EQ(sat.specific_force_frd, Eigen::Vector3d(1, -1, -1) * params.accel.range);
  EXPECT_EQ(sat.rate_frd, Eigen::Vector3d(1, -1, 1) * params.gyro.range);
  EXPECT_NEAR(params.accel.range, 8.0 * 9.80665, 1e-9);
  EXPECT_NEAR(params.gyro.range, 2000.0 * M_PI / 180.0, 1e-9);

  // NaN, +inf and -inf on both sensors; and they survive the float conversion into HIL_SENSOR.
  const ImuReading bad = apply_imu_fault(r, ImuSampleFault::kNonFinite, params);
  for (const Eigen::Vector3d& v : {bad.specific_force_frd, bad.rate_frd}) {
    int nan = 0, pos = 0, neg = 0;
    for (int i = 0; i < 3; ++i) {
      const float x = static_cast<float>(v[i]);
      nan += std::isnan(x);
      pos += std::isinf(x) && x > 0;
      neg += std::isinf(x) && x < 0;
    }
    EXPECT_EQ(nan, 1);
    EXPECT_EQ(pos, 1);
    EXPECT_EQ(neg, 1);
  }
}

// The LANDING_TARGET frames the simulated fix releases, decoded.
std::vector<mavlink::LandingTarget> fixes(const FixErrors& errors, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                                          std::vector<double>* release_delays = nullptr) {
  VisionParams params;
  params.noise_m = 0.0;
  SimulatedVisionFix fix(params, Rng(3, "vision"));
  mavlink::Parser parser;
  std::vector<mavlink::LandingTarget> out;
  for (int k = 0; k < 1000; ++k) {
    const double t = k * 1e-3;
    fix.update(t, p, q, false, errors);
    fix.release_until(t, [&](double when, const uint8_t* d, size_t n) {
      parser.feed(d, n, [&](const mavlink::Frame& f) {
        mavlink::LandingTarget lt;
        if (!mavlink::decode(f, lt)) return;
        out.push_back(lt);
        if (release_delays) release_delays->push_back(when - static_cast<double>(lt.time_usec) * 1e-6);
      });
    });
  }
  return out;
}

TEST(FaultEffects, SimulatedFixLateScaledOrOfADecoy) {
  const Eigen::Vector3d p(0.2, -0.1, -1.5);
  const Eigen::Quaterniond q = q_ib_from_yaw(0.7);
  const Eigen::Vector3d star_b = star_in_body_frd(p, q);

  FixErrors late;
  late.extra_latency_s = 0.2;
  std::vector<double> delays;
  ASSERT_FALSE(fixes(late, p, q, &delays).empty());
  for (double d : delays) EXPECT_NEAR(d, 0.022 + 0.2, 1e-3);

  FixErrors scaled;
  scaled.scale_frd = {1.0, 1.0, 1.01};
  for (const auto& lt : fixes(scaled, p, q)) {
    EXPECT_NEAR(lt.x, star_b.x(), 1e-5);
    EXPECT_NEAR(lt.y, star_b.y(), 1e-5);
    EXPECT_NEAR(lt.z, 1.01 * star_b.z(), 1e-5);
  }

  // The firmware's p = s - R p_B with the decoy's p_B gives the vehicle's position minus the decoy's.
  FixErrors decoy;
  decoy.decoy_ned = Eigen::Vector3d(0.5, 0.3, 0.0);
  for (const auto& lt : fixes(decoy, p, q)) {
    const Eigen::Vector3d seen = -(q * Eigen::Vector3d(lt.x, lt.y, lt.z));
    EXPECT_TRUE(seen.isApprox(p - *decoy.decoy_ned, 1e-5)) << seen.transpose();
  }
}

Eigen::Quaterniond level() { return Eigen::Quaterniond::Identity(); }

// The shipped vehicle's cameras, as the simulator renders them.
SimStereoRig shipped_rig(const CameraParams& params) {
  VehicleParams vp;
  vp.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle vehicle(vp);
  return stereo_rig_from_model(vehicle.model(), params, vp.model_path);
}

TEST(FaultEffects, SecondStarOnTheRenderedFloorIsStarLike) {
  CameraParams params;
  params.distractors = 0;  // a copy touching a distractor would merge with it into another shape
  const SimStereoRig rig = shipped_rig(params);
  StereoCameraRenderer with(params, rig, make_floor_scene(params, Rng(4, "floor")), Rng(4, "camera"));
  StereoCameraRenderer without(params, rig, make_floor_scene(params, Rng(4, "floor")), Rng(4, "camera"));
  // The station knows the cameras as in a flight: from chessboards the simulator renders (cached).
  const std::string calibration = station_calibration_file(rig, params, {QUAD_VISION_STATION, "calibrate"},
                                                           QUAD_TEST_CALIBRATION_CACHE, [](const std::string&) {});
  vis::StereoStarLocator locator(vis::load_calibration(calibration), vis::LocatorSettings{});
  const Eigen::Vector3d p(0.0, 0.0, -1.5);
  const Eigen::Vector2d decoy(0.5, 0.3);
  cv::Mat l1, r1, l2, r2;

  // The copy is drawn: thousands of pixels change by more than the star's contrast's half.
  with.set_decoy(decoy);
  with.render(p, level(), false, l1, r1);
  without.render(p, level(), false, l2, r2);
  cv::Mat diff;
  cv::absdiff(l1, l2, diff);
  EXPECT_GT(cv::countNonZero(diff > 80), 1000);

  // With the star hidden, the station's locator finds the copy where it lies.
  with.render(p, level(), true, l1, r1);
  without.render(p, level(), true, l2, r2);
  const vis::StarFix fix = locator.locate(l1, r1);
  ASSERT_TRUE(fix.found);
  const Eigen::Vector3d b =
      rig.left_mount.R_BC * Eigen::Vector3d(fix.p_left[0], fix.p_left[1], fix.p_left[2]) + rig.left_mount.t_BC;
  const Eigen::Vector3d expected = star_in_body_frd(p - Eigen::Vector3d(decoy.x(), decoy.y(), 0.0), level());
  EXPECT_LT((b - expected).norm(), 0.03);

  // Removed, the floor is the original again (both renderers drew the same noise).
  with.set_decoy(std::nullopt);
  with.render(p, level(), false, l1, r1);
  without.render(p, level(), false, l2, r2);
  EXPECT_EQ(cv::norm(l1, l2, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(r1, r2, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace quad::sim
