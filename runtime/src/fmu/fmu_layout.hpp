// runtime/src/fmu/fmu_layout.hpp -- what `indicial fmu` (tools/cmd_fmu.cpp, which writes
// modelDescription.xml) and the FMU's library (fmu_slave.cpp, which answers the calls) must
// agree on: value references, the resource file, the GUID. One place, so they cannot drift.
//
// Value references (FMI 2.0 numbers them per base type; these are unique over all types):
//   Real   0  input      motion angle, rad       (alpha_rad / phi_rad / psi_rad by axis)
//   Real   1  input      motion rate, rad/s      (q_radps / p_radps / r_radps)
//   Real   2  input      airspeed_mps, m/s
//   Real   3  parameter  initial angle, rad      (the steady state the instance starts in)
//   Real   4  parameter  initial_airspeed_mps
//   Real   10 + c output coefficient c of the model ("CL", "Cm", ... in file order)
//   Integer 100  output  step_status: the indicial status of the last step (indicial.h)
//
// The GUID is a digest of the coefficient file's bytes and of kFmuLayoutVersion: the library
// refuses, at fmi2Instantiate, a resources/model.coef that is not the one the
// modelDescription.xml was written for (damaged, edited or swapped), and a description of an
// older layout. The digest is two FNV-1a 64-bit hashes (different offsets) written as a UUID:
// an identity check, not a cryptographic one (the coefficient file carries its own checksum).
// Written by hand: a dozen lines, and the library must stay free of dependencies.
//
// Warning: changing a value reference or the meaning of a variable changes the binary
// interface of every FMU written before: bump kFmuLayoutVersion.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>

namespace indicial::fmu {

inline constexpr const char* kFmuLayoutVersion = "indicial-fmu-layout-1";

enum ValueReference : unsigned int {
  vr_angle_rad = 0,
  vr_rate_radps = 1,
  vr_airspeed_mps = 2,
  vr_initial_angle_rad = 3,
  vr_initial_airspeed_mps = 4,
  vr_first_coefficient = 10,
  vr_step_status = 100,
};

// The coefficient file inside the FMU, relative to its resources/ folder.
inline constexpr const char* kModelResource = "model.coef";

// Characters of a GUID "{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}" plus the terminating NUL.
inline constexpr std::size_t kGuidChars = 39;

inline std::uint64_t fnv1a64(std::uint64_t h, const unsigned char* p, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;
  }
  return h;
}

// Writes the GUID of a coefficient file's bytes to out (kGuidChars chars with the NUL).
inline void model_guid(const char* text, std::size_t length, char out[kGuidChars]) {
  std::uint64_t h[2] = {0xcbf29ce484222325ull, 0x84222325cbf29ce4ull};
  for (std::uint64_t& x : h) {
    const char* v = kFmuLayoutVersion;
    std::size_t vn = 0;
    while (v[vn] != '\0') ++vn;
    x = fnv1a64(x, reinterpret_cast<const unsigned char*>(v), vn);
    x = fnv1a64(x, reinterpret_cast<const unsigned char*>(text), length);
  }
  std::snprintf(out, kGuidChars, "{%08x-%04x-%04x-%04x-%04x%08x}",
                static_cast<unsigned>(h[0] >> 32), static_cast<unsigned>((h[0] >> 16) & 0xffffu),
                static_cast<unsigned>(h[0] & 0xffffu), static_cast<unsigned>(h[1] >> 48),
                static_cast<unsigned>((h[1] >> 32) & 0xffffu), static_cast<unsigned>(h[1] & 0xffffffffu));
}

}  // namespace indicial::fmu
