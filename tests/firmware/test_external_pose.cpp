// External poses (firmware/include/quad/firmware/external_pose.h): ATT_POS_MOCAP, VISION_POSITION_ESTIMATE
// and the dialect's EXTERNAL_POSE_TARGETED read from received frames (covariance blocks, attitude, the
// target system), and the flight application fusing them: the thesis pair's position, the EKF's position
// and heading, another vehicle's poses ignored, and the capture time from EXT_POSE_DELAY.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <vector>

#include "app_bench.h"
#include "quad/firmware/app.h"
#include "quad/firmware/external_pose.h"

namespace {

using quad::fw::ExternalPose;
using quad::fw::test::Bench;
namespace mav = quad::mavlink;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Encodes msg as sysid 1 compid 197 would, parses it back with the firmware's parser table, and hands
// the frame to decode(frame, &pose); returns what decode returned.
template <class Msg, class Decode>
auto through_frame(const Msg& msg, ExternalPose* pose, Decode decode) {
  mav::Sender sender(1, 197);
  uint8_t buf[mav::max_frame_length<Msg>()];
  const size_t n = sender.encode(msg, buf, sizeof buf);
  mav::Parser parser(mav::dialect_message_info);
  int frames = 0;
  decltype(decode(std::declval<const mav::Frame&>(), pose)) result{};
  parser.feed(buf, n, [&](const mav::Frame& f) {
    ++frames;
    result = decode(f, pose);
  });
  EXPECT_EQ(frames, 1);
  return result;
}

int decode_mocap(const mav::Frame& f, ExternalPose* p) {
  quad::fw::decode_att_pos_mocap(f, p);
  return 0;
}
int decode_vpe(const mav::Frame& f, ExternalPose* p) {
  quad::fw::decode_vision_position_estimate(f, p);
  return 0;
}
int decode_targeted(const mav::Frame& f, ExternalPose* p) { return quad::fw::decode_external_pose_targeted(f, p); }

TEST(ExternalPose, AttPosMocapPositionAttitudeAndCovarianceBlocks) {
  mav::AttPosMocap m;
  m.time_usec = 123456789012ull;
  const Eigen::Quaternionf q = Eigen::Quaternionf(Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1, 2, 3).normalized()));
  m.q[0] = q.w();
  m.q[1] = q.x();
  m.q[2] = q.y();
  m.q[3] = q.z();
  m.x = 1.5f;
  m.y = -2.25f;
  m.z = -0.75f;
  for (int i = 0; i < 21; ++i) m.covariance[i] = 1.0f + static_cast<float>(i);
  ExternalPose pose;
  through_frame(m, &pose, decode_mocap);
  EXPECT_EQ(pose.time_usec, m.time_usec);
  EXPECT_EQ(pose.p_ned.x, 1.5f);
  EXPECT_EQ(pose.p_ned.y, -2.25f);
  EXPECT_EQ(pose.p_ned.z, -0.75f);
  ASSERT_TRUE(pose.has_attitude);
  EXPECT_NEAR(pose.q_ib.w, q.w(), 1e-6f);
  EXPECT_NEAR(pose.q_ib.x, q.x(), 1e-6f);
  EXPECT_NEAR(pose.q_ib.y, q.y(), 1e-6f);
  EXPECT_NEAR(pose.q_ib.z, q.z(), 1e-6f);
  ASSERT_TRUE(pose.has_covariance);
  // The 6x6 upper triangle by rows: xx xy xz at 0 1 2, yy yz at 6 7, zz at 11; roll..yaw block 15..20.
  const float pos[6] = {1, 2, 3, 7, 8, 12}, att[6] = {16, 17, 18, 19, 20, 21};
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(pose.pos_cov[i], pos[i]) << i;
    EXPECT_EQ(pose.att_cov[i], att[i]) << i;
  }
}

TEST(ExternalPose, UnknownOrAbsentCovarianceAndAttitude) {
  mav::AttPosMocap m;
  m.x = 1.0f;
  m.covariance[0] = kNaN;  // MAVLink: unknown
  m.covariance[6] = 0.1f;
  ExternalPose pose;
  through_frame(m, &pose, decode_mocap);
  EXPECT_FALSE(pose.has_covariance);
  EXPECT_FALSE(pose.has_attitude) << "q all zero is no rotation";
  // Without covariance the frame ends after z (MAVLink v2 drops trailing zeros): still a position.
  mav::AttPosMocap bare;
  bare.q[0] = 1.0f;
  bare.x = 2.0f;
  bare.z = -1.0f;
  ExternalPose p2;
  through_frame(bare, &p2, decode_mocap);
  EXPECT_FALSE(p2.has_covariance);
  EXPECT_TRUE(p2.has_attitude);
  EXPECT_EQ(p2.p_ned.x, 2.0f);
  EXPECT_EQ(p2.p_ned.z, -1.0f);
}

TEST(ExternalPose, VisionPositionEstimateEulerAnglesAndCovariance) {
  mav::VisionPositionEstimate v;
  v.usec = 42;
  v.x = 0.5f;
  v.y = 0.25f;
  v.z = -1.25f;
  v.roll = 0.1f;
  v.pitch = -0.2f;
  v.yaw = 2.5f;
  for (int i = 0; i < 21; ++i) v.covariance[i] = 0.01f * static_cast<float>(i + 1);
  v.reset_counter = 3;
  ExternalPose pose;
  through_frame(v, &pose, decode_vpe);
  EXPECT_EQ(pose.time_usec, 42u);
  EXPECT_EQ(pose.p_ned.z, -1.25f);
  ASSERT_TRUE(pose.has_attitude);
  // ZYX: q = Rz(yaw) Ry(pitch) Rx(roll), body to NED.
  const Eigen::Quaternionf q = Eigen::AngleAxisf(2.5f, Eigen::Vector3f::UnitZ()) *
                               Eigen::AngleAxisf(-0.2f, Eigen::Vector3f::UnitY()) *
                               Eigen::AngleAxisf(0.1f, Eigen::Vector3f::UnitX());
  EXPECT_NEAR(std::abs(q.w() * pose.q_ib.w + q.x() * pose.q_ib.x + q.y() * pose.q_ib.y + q.z() * pose.q_ib.z), 1.0f,
              1e-6f);
  ASSERT_TRUE(pose.has_covariance);
  EXPECT_FLOAT_EQ(pose.pos_cov[3], 0.07f);  // yy: element 6
  EXPECT_FLOAT_EQ(pose.pos_cov[5], 0.12f);  // zz: element 11
  EXPECT_FLOAT_EQ(pose.att_cov[5], 0.21f);  // yaw yaw: element 20
  // NaN angles: no attitude.
  v.roll = kNaN;
  through_frame(v, &pose, decode_vpe);
  EXPECT_FALSE(pose.has_attitude);
}

TEST(ExternalPose, TargetedPoseCarriesItsVehicleAndDiagonalVariances) {
  mav::ExternalPoseTargeted t;
  t.target_system = 7;
  t.time_usec = 99;
  t.x = 3.0f;
  t.q[0] = 1.0f;
  t.position_variance[0] = 1e-4f;
  t.position_variance[1] = 2e-4f;
  t.position_variance[2] = 3e-4f;
  t.attitude_variance = kNaN;
  ExternalPose pose;
  EXPECT_EQ(through_frame(t, &pose, decode_targeted), 7);
  EXPECT_EQ(pose.p_ned.x, 3.0f);
  ASSERT_TRUE(pose.has_covariance);
  const float pos[6] = {1e-4f, 0, 0, 2e-4f, 0, 3e-4f};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(pose.pos_cov[i], pos[i]) << i;
  const float default_att = quad::est::EkfParams().attitude_sigma;
  EXPECT_FLOAT_EQ(pose.att_cov[0], default_att * default_att) << "unknown attitude variance: the EKF's default";
  EXPECT_EQ(pose.att_cov[1], 0.0f);
  t.q[0] = kNaN;
  t.position_variance[0] = kNaN;
  through_frame(t, &pose, decode_targeted);
  EXPECT_FALSE(pose.has_attitude);
  EXPECT_FALSE(pose.has_covariance);
}

// ---------------------------------------------------------------------------------------------------
// The flight application.

void boot_calibrated(Bench& b, float est_type, const Eigen::Quaternionf& q = Eigen::Quaternionf::Identity()) {
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kEstType, est_type), nullptr);
  for (int i = 0; i < 1000 && !b.app->calibrated(); ++i) b.still_step(q);
  ASSERT_TRUE(b.app->calibrated());
}

mav::AttPosMocap mocap(const Eigen::Vector3f& p, const Eigen::Quaternionf& q, uint64_t time_usec) {
  mav::AttPosMocap m;
  m.time_usec = time_usec;
  m.q[0] = q.w();
  m.q[1] = q.x();
  m.q[2] = q.y();
  m.q[3] = q.z();
  m.x = p.x();
  m.y = p.y();
  m.z = p.z();
  m.covariance[0] = kNaN;
  return m;
}

mav::ExternalPoseTargeted targeted(uint8_t system, const Eigen::Vector3f& p, uint64_t time_usec) {
  mav::ExternalPoseTargeted t;
  t.target_system = system;
  t.time_usec = time_usec;
  t.x = p.x();
  t.y = p.y();
  t.z = p.z();
  t.q[0] = kNaN;
  t.position_variance[0] = 1e-4f;
  t.position_variance[1] = 1e-4f;
  t.position_variance[2] = 1e-4f;
  t.attitude_variance = kNaN;
  return t;
}

TEST(ExternalPoseApp, ThesisPairFusesMocapAndIgnoresAnotherVehiclesPose) {
  Bench b;
  boot_calibrated(b, 0.0f);
  const Eigen::Vector3f p(0.4f, -0.3f, -1.2f), elsewhere(3.0f, 3.0f, -2.0f);
  mav::Sender ground(1, 197);
  for (int i = 0; i < 150; ++i) {
    b.still_step();
    if (i % 3 != 0) continue;
    b.send(quad::hal::kUart2, mocap(p, Eigen::Quaternionf::Identity(), b.t_us - 20000), ground);
    b.send(quad::hal::kUart2, targeted(2, elsewhere, b.t_us - 20000), ground);  // vehicle 2's
  }
  const quad::Vec3 est = b.app->position();
  EXPECT_NEAR(est.x, p.x(), 0.02f);
  EXPECT_NEAR(est.y, p.y(), 0.02f);
  EXPECT_NEAR(est.z, p.z(), 0.02f);
  EXPECT_EQ(b.app->counters().fixes_received, 50u) << "vehicle 2's poses are not this vehicle's fixes";
  EXPECT_GE(b.app->counters().fixes_fused, 45u);
  // Its own targeted pose is taken; a broadcast (target 0) is not.
  for (int i = 0; i < 60; ++i) {
    b.still_step();
    if (i % 3 == 0) b.send(quad::hal::kUart2, targeted(1, p + Eigen::Vector3f(0.1f, 0, 0), b.t_us - 20000), ground);
    if (i % 3 == 1) b.send(quad::hal::kUart2, targeted(0, elsewhere, b.t_us - 20000), ground);
  }
  EXPECT_EQ(b.app->counters().fixes_received, 70u);
  EXPECT_NEAR(b.app->position().x, p.x() + 0.1f, 0.03f);
}

TEST(ExternalPoseApp, EkfTakesMocapPositionAndHeading) {
  // The vehicle stands at heading 0.8 rad, the magnetometer off in the EKF; motion capture says 1.0 rad:
  // the EKF's heading must go to the mocap's q_IB (a conjugate or the star's quarter turns would not).
  Bench b;
  const Eigen::Quaternionf truth(Eigen::AngleAxisf(0.8f, Eigen::Vector3f::UnitZ()));
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kEstMagUse, 0.0f), nullptr);
  ASSERT_EQ(b.app->override_param(quad::fw::kEstType, 1.0f), nullptr);
  for (int i = 0; i < 1000 && !b.app->calibrated(); ++i) b.still_step(truth);
  ASSERT_TRUE(b.app->calibrated());
  const Eigen::Quaternionf said(Eigen::AngleAxisf(1.0f, Eigen::Vector3f::UnitZ()));
  const Eigen::Vector3f p(-0.5f, 0.2f, -0.1f);
  mav::Sender ground(1, 197);
  for (int i = 0; i < 300; ++i) {
    b.still_step(truth);
    if (i % 3 == 0) b.send(quad::hal::kUart2, mocap(p, said, b.t_us - 30000), ground);
  }
  const quad::Quat q = b.app->attitude();
  const float yaw = std::atan2(2.0f * (q.w * q.z + q.x * q.y), 1.0f - 2.0f * (q.y * q.y + q.z * q.z));
  EXPECT_NEAR(yaw, 1.0f, 0.03f);
  const quad::Vec3 est = b.app->position();
  EXPECT_NEAR(est.x, p.x(), 0.02f);
  EXPECT_NEAR(est.y, p.y(), 0.02f);
  EXPECT_NEAR(est.z, p.z(), 0.02f);
  EXPECT_GE(b.app->counters().fixes_fused, 90u);
}

TEST(ExternalPoseApp, SenderClockNeedsExtPoseDelay) {
  // A mocap PC stamps in its own clock (here: Unix time, whose low 32 bits lie 10 s behind the
  // vehicle's): taken as the vehicle's clock the fixes are too old; with EXT_POSE_DELAY the capture time
  // is the arrival minus the delay and they are fused.
  for (const float delay : {-1.0f, 0.03f}) {
    Bench b;
    boot_calibrated(b, 0.0f);
    ASSERT_EQ(b.app->override_param(quad::fw::kExtPoseDelay, delay), nullptr);
    for (int i = 0; i < 100; ++i) b.still_step();  // the ground hold has set the filter's position
    mav::Sender ground(1, 197);
    const Eigen::Vector3f p(0.2f, 0.1f, -0.5f);
    for (int i = 0; i < 90; ++i) {
      b.still_step();
      const uint64_t unix_us = 1764700000000000ull;
      const uint64_t stamp = (unix_us & ~0xFFFFFFFFull) + static_cast<uint32_t>(b.t_us - 10000000u);
      if (i % 3 == 0) b.send(quad::hal::kUart2, mocap(p, Eigen::Quaternionf::Identity(), stamp), ground);
    }
    if (delay < 0.0f) {
      EXPECT_EQ(b.app->counters().fixes_fused, 0u);
    } else {
      EXPECT_GE(b.app->counters().fixes_fused, 28u);
      EXPECT_NEAR(b.app->position().x, p.x(), 0.02f);
    }
  }
}

}  // namespace
