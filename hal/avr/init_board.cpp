// Bring-up of the APM 2.5's sensors and actuators for the board image (HIL images do not link this).
#include "quad/hal/avr.h"

#include "board.h"

namespace quad {
namespace hal {
namespace avr {

bool start_imu();
bool start_mag();
void start_motors();
void start_rc();

bool init_board() {
  start_motors();  // first: the ESCs see 1000 us (stopped) from the start
  start_rc();
  const bool imu = start_imu();
  const bool mag = start_mag();
  return imu && mag;
}

}  // namespace avr
}  // namespace hal
}  // namespace quad
