// Cortex-M4F hardware-in-the-loop image for QEMU's mps2-an386: sensors from HIL_SENSOR on UART0, motor
// commands back as HIL_ACTUATOR_CONTROLS. Flown processor-in-the-loop by tools/qemu_pil.
#include "quad/firmware/runner.h"
#include "quad/hal/hal.h"

namespace {
quad::fw::FlightApp g_app;
}  // namespace

int main() {
  quad::hal::init();
  quad::fw::init_hil(g_app, quad::fw::hal_app_io());
  quad::fw::run_hil(g_app);
}
