// The HIL loop: only the clock, the serial ports and the storage of the HAL (hosts link this alone).
#include "quad/firmware/runner.h"

#include "quad/firmware/hil_bridge.h"
#include "quad/hal/hal.h"

namespace quad {
namespace fw {

namespace {

uint16_t write_port(uint8_t port, const uint8_t* data, uint16_t length) {
  return hal::serial_write(static_cast<hal::Port>(port), data, length);
}
uint16_t port_tx_free(uint8_t port) { return hal::serial_tx_free(static_cast<hal::Port>(port)); }

HilBridge g_bridge;

}  // namespace

AppIo hal_app_io() {
  AppIo io;
  io.storage = StorageIo{hal::storage_read, hal::storage_write};
  io.write = write_port;
  io.tx_free = port_tx_free;
  io.micros = hal::micros;
  io.trace = hal::trace;
  return io;
}

void init_hil(FlightApp& app, AppIo io) {
  g_bridge.connect(app, io);
  app.init(io);
}

void poll_ports(FlightApp& app) {
  uint8_t buffer[32];  // under every iteration in HIL (the ATmega2560 counts the peak stack)
  for (uint8_t port = 0; port < hal::kPortCount; ++port) {
    uint16_t n;
    while ((n = hal::serial_read(static_cast<hal::Port>(port), buffer, sizeof buffer)) > 0) {
      app.receive(port, buffer, n, hal::micros());
    }
  }
}

void run_hil(FlightApp& app) {
  for (;;) {
    hal::idle(20000);
    poll_ports(app);
    hal::led_write(app.led(hal::micros()));
  }
}

}  // namespace fw
}  // namespace quad
