// firmware/cortex-m/instruction_counter.hpp -- counting executed instructions under QEMU.
//
// Method (see firmware/cortex-m/README.md, "Counting instructions"): QEMU runs the firmware
// with `-icount shift=0`, which makes its virtual clock advance exactly 1 ns per executed
// guest instruction (2^shift ns), whatever the host does. The SysTick timer of the MPS2's
// Cortex-M4, set to the processor clock (25 MHz on mps2-an386), counts that virtual clock:
// one SysTick tick is 40 ns, i.e. 40 instructions. A window is the difference of two reads
// of the 24-bit down counter; it holds up to 2^24 ticks (671 million instructions).
// Resolution: one tick (40 instructions) per window, so windows are long (a whole replay
// segment) and the per-step figure is (window with the step - the same window with an empty
// function in its place) / steps. A real Cortex-M4 would count cycles here, not instructions:
// the figures are instruction counts only because of -icount under QEMU (the firmware's
// calibration loop, which checks the method against loops of known length, says so too).
#pragma once

#include <cstdint>

namespace fw {

struct SysTick {
  std::uint32_t csr, rvr, cvr, calib;
};

inline volatile SysTick& systick() { return *reinterpret_cast<volatile SysTick*>(0xE000E010u); }

// Starts the free-running counter on the processor clock (CLKSOURCE = 1, no interrupt).
inline void start_counter() {
  systick().csr = 0;
  systick().rvr = 0x00FFFFFFu;
  systick().cvr = 0;
  systick().csr = 0x5u;  // ENABLE | CLKSOURCE
}

// Ticks elapsed since start_counter(), modulo 2^24 (the counter counts down).
inline std::uint32_t counter_ticks() { return (0x00FFFFFFu - systick().cvr) & 0x00FFFFFFu; }

inline std::uint32_t ticks_between(std::uint32_t from, std::uint32_t to) {
  return (to - from) & 0x00FFFFFFu;
}

}  // namespace fw
