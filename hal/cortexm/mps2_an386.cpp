// QEMU's mps2-an386 (Cortex-M4F at 25 MHz): the board-specific part of the Cortex-M HAL.
//
//   hal port   device              base         NVIC RX / TX   QEMU option
//   kUart0     CMSDK APB UART0     0x40004000   0 / 1          first  -serial
//   kUart2     CMSDK APB UART1     0x40005000   2 / 3          second -serial
//   LED        FPGA IO LED0        0x40028000
//   storage    4 KiB of RAM: the emulated board has no writable flash, so parameters last until reset
//              (a real STM32F4 board keeps them in a flash sector behind the same two functions). The
//              array `quad_storage` sits in .noinit, outside the zeroed .bss, so a launcher can preload
//              it (tools/qemu_pil: QEMU's -device loader with the blob of tools/qemu_pil/param_image).
#include <string.h>

#include "board.h"
#include "ring.h"

// The parameter storage, at a symbol a launcher can find (arm-none-eabi-nm) and preload.
extern "C" {
__attribute__((section(".noinit"))) uint8_t quad_storage[4096];
}

namespace quad {
namespace hal {
namespace cortexm {

const uint32_t kCoreClockHz = 25000000u;

namespace {

// CMSDK APB UART (ARM DDI 0479C, 4.3): a one-byte buffer each way.
struct CmsdkUart {
  volatile uint32_t data;
  volatile uint32_t state;      // bit 0 TX full, bit 1 RX full
  volatile uint32_t ctrl;       // bit 0 TX enable, 1 RX enable, 2 TX interrupt, 3 RX interrupt
  volatile uint32_t intstatus;  // write 1 to clear: bit 0 TX, bit 1 RX
  volatile uint32_t bauddiv;
};
constexpr uint32_t kTxFull = 1u << 0, kRxFull = 1u << 1;
constexpr uint32_t kTxEnable = 1u << 0, kRxEnable = 1u << 1, kTxInt = 1u << 2, kRxInt = 1u << 3;
constexpr uint32_t kIntTx = 1u << 0, kIntRx = 1u << 1;

volatile uint32_t& kNvicIser0 = *reinterpret_cast<volatile uint32_t*>(0xE000E100u);
volatile uint32_t& kFpgaIoLed = *reinterpret_cast<volatile uint32_t*>(0x40028000u);

struct UartChannel {
  CmsdkUart* uart;
  ByteRing<512> rx;
  ByteRing<512> tx;

  void start(uint32_t baud) {
    uart->bauddiv = kCoreClockHz / baud;  // QEMU times nothing by it; a real UART would
    uart->ctrl = kTxEnable | kRxEnable | kTxInt | kRxInt;
  }
  void on_rx_interrupt() {
    uart->intstatus = kIntRx;
    while (uart->state & kRxFull) rx.push(static_cast<uint8_t>(uart->data));  // full ring: byte lost
  }
  void on_tx_interrupt() {
    uart->intstatus = kIntTx;
    if (!tx.empty() && !(uart->state & kTxFull)) uart->data = tx.pop();
  }
};

UartChannel g_ports[kPortCount] = {{reinterpret_cast<CmsdkUart*>(0x40004000u), {}, {}},
                            {reinterpret_cast<CmsdkUart*>(0x40005000u), {}, {}}};

constexpr uint16_t kStorageSize = sizeof quad_storage;

uint32_t disable_irq() {
  uint32_t primask;
  __asm volatile("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
  return primask;
}
void restore_irq(uint32_t primask) { __asm volatile("msr primask, %0" ::"r"(primask) : "memory"); }

}  // namespace

void board_init() {
  // Never preloaded: QEMU's RAM starts zeroed. Count that as erased storage (the parameters' defaults),
  // as a new EEPROM or flash sector would read.
  bool preloaded = false;
  for (uint16_t i = 0; i < kStorageSize && !preloaded; ++i) preloaded = quad_storage[i] != 0;
  if (!preloaded) memset(quad_storage, 0xFF, sizeof quad_storage);
  g_ports[kUart0].start(921600u);
  g_ports[kUart2].start(57600u);
  kNvicIser0 = (1u << 0) | (1u << 1) | (1u << 2) | (1u << 3);
  kFpgaIoLed = 0;
}

bool board_rx_pending() { return !g_ports[kUart0].rx.empty() || !g_ports[kUart2].rx.empty(); }

}  // namespace cortexm

uint16_t serial_read(Port port, uint8_t* dst, uint16_t capacity) {
  auto& p = cortexm::g_ports[port];
  uint16_t n = 0;
  while (n < capacity && !p.rx.empty()) dst[n++] = p.rx.pop();
  return n;
}

uint16_t serial_write(Port port, const uint8_t* src, uint16_t length) {
  auto& p = cortexm::g_ports[port];
  const uint32_t primask = cortexm::disable_irq();
  const uint16_t room = p.tx.free_space();
  const uint16_t n = length < room ? length : room;
  for (uint16_t i = 0; i < n; ++i) p.tx.push(src[i]);
  // An idle transmitter raises no interrupt by itself: start it; each sent byte then fetches the next.
  if (!p.tx.empty() && !(p.uart->state & cortexm::kTxFull)) p.uart->data = p.tx.pop();
  cortexm::restore_irq(primask);
  return n;
}

uint16_t serial_tx_free(Port port) {
  const uint32_t primask = cortexm::disable_irq();
  const uint16_t room = cortexm::g_ports[port].tx.free_space();
  cortexm::restore_irq(primask);
  return room;
}

uint16_t storage_size() { return cortexm::kStorageSize; }

bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  if (static_cast<uint32_t>(offset) + length > cortexm::kStorageSize) return false;
  memcpy(dst, quad_storage + offset, length);
  return true;
}

bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  if (static_cast<uint32_t>(offset) + length > cortexm::kStorageSize) return false;
  memcpy(quad_storage + offset, src, length);
  return true;
}

void led_write(bool on) { cortexm::kFpgaIoLed = on ? 1u : 0u; }

void trace(TracePoint) {}  // QEMU's -icount counts the Cortex-M iteration instead (docs/performance.md)

}  // namespace hal
}  // namespace quad

extern "C" void Irq0_Handler() { quad::hal::cortexm::g_ports[quad::hal::kUart0].on_rx_interrupt(); }
extern "C" void Irq1_Handler() { quad::hal::cortexm::g_ports[quad::hal::kUart0].on_tx_interrupt(); }
extern "C" void Irq2_Handler() { quad::hal::cortexm::g_ports[quad::hal::kUart2].on_rx_interrupt(); }
extern "C" void Irq3_Handler() { quad::hal::cortexm::g_ports[quad::hal::kUart2].on_tx_interrupt(); }
