// Core image for the cross targets until hal/avr and hal/cortexm implement the board HAL: the whole
// flight application runs on inputs the compiler cannot see (volatile), so every routine is linked,
// the cross compilers check the freestanding rule, and the size report shows what the application
// costs in flash and RAM. Storage is a RAM array standing in for the EEPROM; frames go to a sink.
#include <string.h>

#include "quad/firmware/app.h"
#include "quad/firmware/storage_layout.h"

namespace {

volatile float g_in[7] = {0.0f, 0.0f, -9.80665f, 0.01f, 0.0f, 0.0f, 0.3f};
volatile float g_motor_out[quad::hal::kMotorCount];
volatile uint8_t g_tx_sink;
volatile uint8_t g_rx_byte;

// Exactly the records the application keeps (storage_layout.h).
uint8_t g_storage[quad::fw::kStorageUsed];

bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  if (offset + length > sizeof g_storage) return false;
  memcpy(dst, g_storage + offset, length);
  return true;
}

bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  if (offset + length > sizeof g_storage) return false;
  memcpy(g_storage + offset, src, length);
  return true;
}

uint16_t write_port(uint8_t, const uint8_t* data, uint16_t length) {
  for (uint16_t i = 0; i < length; ++i) g_tx_sink = data[i];
  return length;
}

uint32_t g_clock_us = 0;
uint32_t micros() { return g_clock_us; }

quad::fw::FlightApp g_app;

}  // namespace

int main() {
  memset(g_storage, 0xFF, sizeof g_storage);
  quad::fw::AppIo io;
  io.storage = quad::fw::StorageIo{storage_read, storage_write};
  io.write = write_port;
  io.micros = micros;
  g_app.init(io);
  for (;;) {
    g_clock_us += 10000u;
    quad::hal::ImuSample imu;
    imu.accel = quad::Vec3{g_in[0], g_in[1], g_in[2]};
    imu.gyro = quad::Vec3{g_in[3], g_in[4], g_in[5]};
    quad::hal::MagSample mag;
    mag.field = quad::Vec3{g_in[6], 0.0f, 0.4f};
    const uint8_t byte = g_rx_byte;
    g_app.receive(quad::hal::kUart2, &byte, 1, g_clock_us);
    g_app.step(g_clock_us, imu, &mag);
    for (uint8_t i = 0; i < quad::hal::kMotorCount; ++i) g_motor_out[i] = g_app.motors()[i];
  }
}
