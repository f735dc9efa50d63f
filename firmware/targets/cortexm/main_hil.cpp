// Cortex-M4F hardware-in-the-loop image for QEMU's mps2-an386: sensors from HIL_SENSOR on UART0, motor
// commands back as HIL_ACTUATOR_CONTROLS. Flown processor-in-the-loop by tools/qemu_pil.
// The flight logs live in 2 MiB of the board's RAM (ram_log_store.h), in .noinit: not zeroed at boot.
#include "quad/firmware/ram_log_store.h"
#include "quad/firmware/runner.h"
#include "quad/hal/hal.h"

namespace {
quad::fw::FlightApp g_app;
quad::fw::RamLogStore g_logs;
__attribute__((section(".noinit"))) uint8_t g_log_region[2u << 20];
}  // namespace

int main() {
  quad::hal::init();
  g_logs.init(g_log_region, sizeof g_log_region);
  quad::fw::AppIo io = quad::fw::hal_app_io();
  io.log_store = &g_logs.store();
  quad::fw::init_hil(g_app, io);
  quad::fw::run_hil(g_app);
}
