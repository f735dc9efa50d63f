// Reset and vector table for a Cortex-M4F: copy .data, clear .bss, enable the FPU, run static
// constructors, call main(). Board-independent: the memory map lives in the linker script, and the
// board's drivers define the external interrupt handlers they use (IrqN_Handler, N = the NVIC number).
#include <stdint.h>

extern "C" {
extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int main();

void Reset_Handler();
void Default_Handler() {
  for (;;) {
  }
}
void NMI_Handler() __attribute__((weak, alias("Default_Handler")));
void HardFault_Handler() __attribute__((weak, alias("Default_Handler")));
void MemManage_Handler() __attribute__((weak, alias("Default_Handler")));
void BusFault_Handler() __attribute__((weak, alias("Default_Handler")));
void UsageFault_Handler() __attribute__((weak, alias("Default_Handler")));
void SVC_Handler() __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler() __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler() __attribute__((weak, alias("Default_Handler")));
#define QUAD_EXTERNAL_IRQ(n) void Irq##n##_Handler() __attribute__((weak, alias("Default_Handler")));
QUAD_EXTERNAL_IRQ(0) QUAD_EXTERNAL_IRQ(1) QUAD_EXTERNAL_IRQ(2) QUAD_EXTERNAL_IRQ(3)
QUAD_EXTERNAL_IRQ(4) QUAD_EXTERNAL_IRQ(5) QUAD_EXTERNAL_IRQ(6) QUAD_EXTERNAL_IRQ(7)
QUAD_EXTERNAL_IRQ(8) QUAD_EXTERNAL_IRQ(9) QUAD_EXTERNAL_IRQ(10) QUAD_EXTERNAL_IRQ(11)
QUAD_EXTERNAL_IRQ(12) QUAD_EXTERNAL_IRQ(13) QUAD_EXTERNAL_IRQ(14) QUAD_EXTERNAL_IRQ(15)
#undef QUAD_EXTERNAL_IRQ

// 16 system exceptions, then the first 16 external interrupts (enough for the boards used so far).
__attribute__((section(".isr_vector"), used)) void (*const g_vectors[32])() = {
    reinterpret_cast<void (*)()>(&_estack),
    Reset_Handler,
    NMI_Handler,
    HardFault_Handler,
    MemManage_Handler,
    BusFault_Handler,
    UsageFault_Handler,
    nullptr,
    nullptr,
    nullptr,
    nullptr,
    SVC_Handler,
    nullptr,
    nullptr,
    PendSV_Handler,
    SysTick_Handler,
    Irq0_Handler,
    Irq1_Handler,
    Irq2_Handler,
    Irq3_Handler,
    Irq4_Handler,
    Irq5_Handler,
    Irq6_Handler,
    Irq7_Handler,
    Irq8_Handler,
    Irq9_Handler,
    Irq10_Handler,
    Irq11_Handler,
    Irq12_Handler,
    Irq13_Handler,
    Irq14_Handler,
    Irq15_Handler,
};

void Reset_Handler() {
  uint32_t* src = &_sidata;
  for (uint32_t* dst = &_sdata; dst < &_edata;) *dst++ = *src++;
  for (uint32_t* dst = &_sbss; dst < &_ebss;) *dst++ = 0u;
  // CPACR: full access to coprocessors 10 and 11 (the single-precision FPU) before any float code.
  volatile uint32_t* const cpacr = reinterpret_cast<volatile uint32_t*>(0xE000ED88u);
  *cpacr |= (0xFu << 20);
  __asm volatile("dsb\n isb" ::: "memory");
  for (void (**ctor)() = __init_array_start; ctor < __init_array_end; ++ctor) (*ctor)();
  main();
  for (;;) {
  }
}
}
