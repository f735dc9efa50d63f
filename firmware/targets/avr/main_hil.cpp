// APM 2.5 hardware-in-the-loop image: the sensors come from the simulator as HIL_SENSOR on UART0 and
// the motor commands go back as HIL_ACTUATOR_CONTROLS (PX4's HIL convention); the board's own sensors
// and ESC outputs stay off. Flown processor-in-the-loop on simavr by tools/avr_pil.
#include "dataflash_log_store.h"
#include "quad/firmware/runner.h"
#include "quad/hal/hal.h"

namespace {
quad::fw::FlightApp g_app;  // static: the 8 KiB of RAM hold no room for it on the stack
}  // namespace

int main() {
  quad::hal::init();
  quad::fw::AppIo io = quad::fw::hal_app_io();
  if (quad::hal::avr::dataflash_start()) io.log_store = &quad::fw::kDataflashLogStore;
  quad::fw::init_hil(g_app, io);
  quad::fw::run_hil(g_app);
}
