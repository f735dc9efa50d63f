#include "quad/firmware/hil_bridge.h"

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

namespace {

// HIL_SENSOR.fields_updated: bits 6..8 flag a new magnetometer sample.
constexpr uint32_t kHilMagFields = 0x1C0u;

// The decoded message lives only in this call's frame, not under the iteration's (the AVR's peak stack).
__attribute__((noinline)) bool decode_sample(const mav::Frame& frame, HilBridge::Sample* s) {
  mav::HilSensor msg;
  if (!mav::decode(frame, msg)) return false;
  s->time_usec = msg.time_usec;
  s->imu.accel = Vec3{msg.xacc, msg.yacc, msg.zacc};
  s->imu.gyro = Vec3{msg.xgyro, msg.ygyro, msg.zgyro};
  s->mag.field = Vec3{msg.xmag, msg.ymag, msg.zmag};
  s->mag_new = (msg.fields_updated & kHilMagFields) != 0;
  return true;
}

}  // namespace

void HilBridge::connect(FlightApp& app, AppIo& io) {
  app_ = &app;
  io.hil_sensor = &HilBridge::on_frame;
  io.hil_context = this;
}

void HilBridge::on_frame(void* bridge, const mav::Frame& frame) {
  Sample s;
  if (decode_sample(frame, &s)) static_cast<HilBridge*>(bridge)->on_sample(s);
}

void HilBridge::on_sample(const Sample& s) {
  if (app_->stepped() && s.time_usec == app_->hil_time_usec()) {
    // The simulator repeated a step whose answer it missed: answer again, do not step twice.
    send_actuators(s.time_usec);
    return;
  }
  app_->hil_step(s.time_usec, s.imu, s.mag_new ? &s.mag : nullptr);
  send_actuators(s.time_usec);
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
