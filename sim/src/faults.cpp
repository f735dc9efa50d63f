#include "quad/sim/faults.h"

#include <algorithm>

namespace quad::sim {

FaultEffects fault_effects(const std::vector<Fault>& faults, const RadioConditions& base_radio, double t) {
  FaultEffects e;
  e.radio = base_radio;
  for (const Fault& f : faults) {
    if (!f.active(t)) continue;
    switch (f.type) {
      case FaultType::kRadioLoss: e.radio.loss = std::max(e.radio.loss, f.value); break;
      case FaultType::kBitErrorRate: e.radio.bit_error_rate = std::max(e.radio.bit_error_rate, f.value); break;
      case FaultType::kRadioLatency: e.radio.latency_s = f.value; break;
      case FaultType::kMagDisturbance: e.mag_offset_ned_gauss += f.vector; break;
      case FaultType::kGyroBiasStep: e.gyro_bias_step_rad_s += f.vector; break;
      case FaultType::kMotorEfficiency: e.motor_efficiency[static_cast<size_t>(f.motor)] *= f.value; break;
      case FaultType::kVisionDropout: e.vision_dropout = true; break;
      case FaultType::kRcLoss: e.rc_loss = true; break;
    }
  }
  return e;
}

const char* fault_name(FaultType type) {
  switch (type) {
    case FaultType::kVisionDropout: return "vision dropout";
    case FaultType::kRadioLoss: return "radio loss";
    case FaultType::kBitErrorRate: return "bit error rate";
    case FaultType::kRadioLatency: return "radio latency";
    case FaultType::kMagDisturbance: return "magnetic disturbance";
    case FaultType::kGyroBiasStep: return "gyro bias step";
    case FaultType::kMotorEfficiency: return "motor efficiency";
    case FaultType::kRcLoss: return "RC loss";
  }
  return "?";
}

}  // namespace quad::sim
