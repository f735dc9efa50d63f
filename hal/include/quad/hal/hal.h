// The hardware abstraction the flight application sees.
//
// Plain functions, one definition per target, chosen at link time (hal/host, hal/avr, hal/cortexm):
// no virtual dispatch, no function pointers on the hot path, nothing allocated. A target defines the
// functions its images use; an image that takes its sensors from the simulator (HIL) references only
// the clock, the serial ports, the storage and the LED, so a target without sensor drivers (the host)
// links HIL images only.
//
// Units at this boundary are SI in the body frame FRD, as everywhere in the flight core: a driver
// converts its raw counts before returning a sample.
#pragma once

#include <stdint.h>

#include "quad/math/vec3.h"

namespace quad {
namespace hal {

// The two serial ports of the APM 2.5: UART0 is the USB port (HIL, telemetry), UART2 the radio.
enum Port : uint8_t { kUart0 = 0, kUart2 = 1, kPortCount = 2 };

struct ImuSample {
  Vec3 accel;  // specific force, m/s^2, FRD (0, 0, -g when level at rest)
  Vec3 gyro;   // angular rate, rad/s, FRD
};

struct MagSample {
  Vec3 field;  // gauss, FRD
};

// RC receiver: pulse widths in microseconds (1000..2000, mid 1500), thesis sec. 6.1.4.
constexpr uint8_t kRcChannels = 8;
struct RcFrame {
  uint16_t pulse_us[kRcChannels];
  uint8_t count;  // channels present in this frame
};

constexpr uint8_t kMotorCount = 4;

// Brings up clocks, ports and storage. Host: configured beforehand by hal::host::configure().
void init();

// Free-running microsecond clock; wraps after 71.6 minutes, so compare times by unsigned difference.
uint32_t micros();

// Waits until a byte may have arrived or `max_wait_us` passed (host: poll(); MCU: sleep until an IRQ).
void idle(uint32_t max_wait_us);

// Non-blocking serial I/O: read returns the number of bytes copied (0 when none are waiting); write
// queues as many bytes as fit and returns that number.
uint16_t serial_read(Port port, uint8_t* dst, uint16_t capacity);
uint16_t serial_write(Port port, const uint8_t* src, uint16_t length);
// Bytes serial_write() would take now (the transmit queue's free space; on the host, the room a UART of
// the port's baud rate with the AVR's queue would have).
uint16_t serial_tx_free(Port port);

// Persistent storage for the parameters (EEPROM on the AVR, a file on the host). Returns false when
// the range lies outside the storage or the device fails.
uint16_t storage_size();
bool storage_read(uint16_t offset, void* dst, uint16_t length);
bool storage_write(uint16_t offset, const void* src, uint16_t length);

// Status LED.
void led_write(bool on);

// Phases of the flight application's work, marked for a processor-in-the-loop profiler: on the AVR a
// one-cycle write of the phase number to GPIOR1, which tools/avr_pil times to the cycle
// (docs/performance.md, "The firmware's own iteration"); a no-op on the other targets.
enum class TracePoint : uint8_t {
  kStepBegin = 1,     // a control iteration starts (sensor sample in hand)
  kControlIdle = 2,   // estimation, modes and control done; disarmed, no motor command computed
  kControlFlown = 3,  // estimation, modes and control done; the cascade computed the motor commands
  kStepEnd = 4,       // landing detection, telemetry and parameter streaming done
  kFixBegin = 5,      // a vision fix is about to be fused
  kFixEnd = 6,
  // Stage boundaries inside an iteration (FlightApp::step), each the end of the stage before it: the
  // estimator (kStepBegin or a fix step to kEstimated), the mode machine (to kModesDone), control (to
  // kControlIdle/kControlFlown), landing detection and telemetry (to kTelemetryDone), the parameter
  // stream (to kStepEnd).
  kEstimated = 7,
  kModesDone = 8,
  kTelemetryDone = 9,
};
void trace(TracePoint point);

// Board sensors and actuators, defined only by targets that have them (not the host).
bool imu_read(ImuSample& out);  // true when a new sample arrived since the last call
bool mag_read(MagSample& out);  // true when a new sample arrived since the last call
bool rc_read(RcFrame& out);     // true when a new frame arrived since the last call
void motors_write(const float (&command)[kMotorCount]);  // 0..1 per motor; all 0 stops the motors

}  // namespace hal
}  // namespace quad
