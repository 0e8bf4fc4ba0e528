// firmware/cortex-m/semihosting.hpp -- the few Arm semihosting calls the Cortex-M replay
// firmware makes (open, read, write, close, exit), through `bkpt 0xab` as the Arm
// "Semihosting for AArch32 and AArch64" specification defines them. QEMU serves them with
// `-semihosting-config enable=on,target=native`: the files are the host's.
//
// Written by hand, not taken from newlib's librdimon: librdimon brings newlib's stdio, whose
// buffers come from malloc, and this firmware must link without malloc (see
// firmware/cortex-m/README.md). The calls are only made outside the measured windows.
#pragma once

#include <cstddef>
#include <cstdint>

namespace fw {

enum class SemihostingOp : std::uint32_t {
  open = 0x01, close = 0x02, write0 = 0x04, write = 0x05, read = 0x06, flen = 0x0c,
  exit_extended = 0x20,
};

inline std::int32_t semihost(SemihostingOp op, const void* arg) {
  register std::uint32_t r0 asm("r0") = static_cast<std::uint32_t>(op);
  register const void* r1 asm("r1") = arg;
  asm volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
  return static_cast<std::int32_t>(r0);
}

enum class OpenMode : std::uint32_t { read_binary = 1, write_binary = 5 };  // "rb", "wb"

inline std::size_t length_of(const char* s) {
  std::size_t n = 0;
  while (s[n] != '\0') ++n;
  return n;
}

// A host file handle (>= 0), or -1.
inline std::int32_t open_file(const char* path, OpenMode mode) {
  const std::uint32_t block[3] = {reinterpret_cast<std::uint32_t>(path),
                                  static_cast<std::uint32_t>(mode),
                                  static_cast<std::uint32_t>(length_of(path))};
  return semihost(SemihostingOp::open, block);
}

// Bytes NOT read (0: all of them), as the specification returns it.
inline std::int32_t read_file(std::int32_t handle, void* buffer, std::size_t n) {
  const std::uint32_t block[3] = {static_cast<std::uint32_t>(handle),
                                  reinterpret_cast<std::uint32_t>(buffer),
                                  static_cast<std::uint32_t>(n)};
  return semihost(SemihostingOp::read, block);
}

inline std::int32_t file_length(std::int32_t handle) {
  const std::uint32_t block[1] = {static_cast<std::uint32_t>(handle)};
  return semihost(SemihostingOp::flen, block);
}

// Bytes NOT written (0: all of them).
inline std::int32_t write_file(std::int32_t handle, const void* buffer, std::size_t n) {
  const std::uint32_t block[3] = {static_cast<std::uint32_t>(handle),
                                  reinterpret_cast<std::uint32_t>(buffer),
                                  static_cast<std::uint32_t>(n)};
  return semihost(SemihostingOp::write, block);
}

inline void close_file(std::int32_t handle) {
  const std::uint32_t block[1] = {static_cast<std::uint32_t>(handle)};
  semihost(SemihostingOp::close, block);
}

// Text on the host's stderr (the debug console).
inline void print(const char* s) { semihost(SemihostingOp::write0, s); }

// Ends the QEMU run with this exit status (ADP_Stopped_ApplicationExit and the code).
[[noreturn]] inline void exit_with(int code) {
  const std::uint32_t block[2] = {0x20026u, static_cast<std::uint32_t>(code)};
  semihost(SemihostingOp::exit_extended, block);
  for (;;) {
  }
}

}  // namespace fw
