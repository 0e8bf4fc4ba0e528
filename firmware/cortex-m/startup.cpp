// firmware/cortex-m/startup.cpp -- reset handler and vector table of the Cortex-M replay
// firmware (mps2-an386.ld): copies .data, clears .bss, enables the FPU (CP10/CP11), runs the
// static constructors, calls main and ends the QEMU run with main's status (semihosting).
// Written by hand (about 40 lines) rather than taken from CMSIS: Debian packages no CMSIS
// device startup for the MPS2, and these are the only things the firmware needs at reset.
//
// Also the two C/C++ library symbols the coef_text variant needs and that newlib's own
// versions would drag the heap in with (firmware/cortex-m/README.md, "What the runtime needs
// from the C++ library"): abort() (newlib's raises a signal, whose table is malloc'ed) and
// __gxx_personality_v0 (std::from_chars is compiled with unwind tables that name it; this
// firmware is -fno-exceptions and never unwinds, so it is never called).
#include <cstdint>

#include "semihosting.hpp"

extern "C" {
extern std::uint32_t __data_start, __data_end, __data_load, __bss_start, __bss_end, __stack_top;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int main();
[[noreturn]] void reset_handler();
[[noreturn]] void fault_handler();
[[noreturn]] void abort();
[[noreturn]] void __gxx_personality_v0();
}

// Everything here runs before the FPU is enabled: integer code only (no float in this file).
[[noreturn]] void reset_handler() {
  const std::uint32_t* src = &__data_load;
  for (std::uint32_t* dst = &__data_start; dst < &__data_end;) *dst++ = *src++;
  for (std::uint32_t* dst = &__bss_start; dst < &__bss_end;) *dst++ = 0;
  volatile std::uint32_t* const cpacr = reinterpret_cast<volatile std::uint32_t*>(0xE000ED88u);
  *cpacr = *cpacr | (0xFu << 20);  // CP10 and CP11: full access to the FPU
  asm volatile("dsb\n\tisb" ::: "memory");
  for (void (**f)() = __init_array_start; f < __init_array_end; ++f) (*f)();
  fw::exit_with(main());
}

// Any fault (a bad access, an undefined instruction, an FPU instruction before CPACR) ends the
// run with status 3 instead of hanging QEMU.
[[noreturn]] void fault_handler() {
  fw::print("firmware: fault\n");
  fw::exit_with(3);
}

[[noreturn]] void abort() {
  fw::print("firmware: abort\n");
  fw::exit_with(4);
}

[[noreturn]] void __gxx_personality_v0() {
  fw::print("firmware: an exception was thrown (built with -fno-exceptions)\n");
  fw::exit_with(5);
}

// The vector table: initial stack pointer, reset, then NMI, HardFault, MemManage, BusFault,
// UsageFault (the remaining exceptions are never enabled).
__attribute__((section(".vectors"), used)) const void* const vector_table[8] = {
    &__stack_top,
    reinterpret_cast<const void*>(&reset_handler),
    reinterpret_cast<const void*>(&fault_handler),
    reinterpret_cast<const void*>(&fault_handler),
    reinterpret_cast<const void*>(&fault_handler),
    reinterpret_cast<const void*>(&fault_handler),
    reinterpret_cast<const void*>(&fault_handler),
    nullptr,
};
