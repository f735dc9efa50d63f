// APM 2.5 flight image: MPU-6000, HMC5883L, PPM receiver and ESCs through the board HAL, the control
// loop at SYS_LOOP_HZ. Flashed with `make flash PORT=/dev/ttyACM0` (docs/targets.md).
#include "dataflash_log_store.h"
#include "quad/firmware/runner.h"
#include "quad/hal/avr.h"
#include "quad/hal/hal.h"

namespace {
quad::fw::FlightApp g_app;
}  // namespace

int main() {
  quad::hal::init();
  // A sensor that does not answer leaves its driver silent; the application's sensor health check
  // then refuses to arm and reports it over MAVLink, which is more useful than stopping here.
  quad::hal::avr::init_board();
  quad::fw::AppIo io = quad::fw::hal_app_io();
  if (quad::hal::avr::dataflash_start()) io.log_store = &quad::fw::kDataflashLogStore;
  g_app.init(io);
  quad::fw::run_board(g_app);
}
