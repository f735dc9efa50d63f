#include "quad/firmware/hil_bridge.h"

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

namespace {

// HIL_SENSOR.fields_updated: bits 6..8 flag a new magnetometer sample.
constexpr uint32_t kHilMagFields = 0x1C0u;

}  // namespace

void HilBridge::connect(FlightApp& app, AppIo& io) {
  app_ = &app;
  io.hil_sensor = &HilBridge::on_frame;
  io.hil_context = this;
}

void HilBridge::on_frame(void* bridge, const mav::Frame& frame) {
  mav::HilSensor msg;
  if (mav::decode(frame, msg)) static_cast<HilBridge*>(bridge)->on_sensor(msg);
}

void HilBridge::on_sensor(const mav::HilSensor& msg) {
  ++sensor_frames_;
  if (stepped_ && msg.time_usec == time_usec_) {
    // The simulator repeated a step whose answer it missed: answer again, do not step twice.
    send_actuators(msg.time_usec);
    return;
  }
  stepped_ = true;
  time_usec_ = msg.time_usec;
  hal::ImuSample imu;
  imu.accel = Vec3{msg.xacc, msg.yacc, msg.zacc};
  imu.gyro = Vec3{msg.xgyro, msg.ygyro, msg.zgyro};
  hal::MagSample mag;
  mag.field = Vec3{msg.xmag, msg.ymag, msg.zmag};
  const bool mag_new = (msg.fields_updated & kHilMagFields) != 0;
  app_->hil_step(msg.time_usec, imu, mag_new ? &mag : nullptr);
  send_actuators(msg.time_usec);
}

void HilBridge::send_actuators(uint64_t time_usec) {
  mav::HilActuatorControls out;
  out.time_usec = time_usec;
  for (uint8_t i = 0; i < hal::kMotorCount; ++i) out.controls[i] = app_->motors()[i];
  out.mode = base_mode(app_->armed(), true);
  // One answer per HIL_SENSOR, stamped with its time, in both modes; the flag says which one the
  // simulator asked for (HIL_LOCKSTEP), as PX4's does.
  out.flags = app_->params().get(kHilLockstep) >= 0.5f ? mav::kHilActuatorControlsFlagLockstep : 0;
  app_->link().send(hal::kUart0, out);
}

}  // namespace fw
}  // namespace quad
