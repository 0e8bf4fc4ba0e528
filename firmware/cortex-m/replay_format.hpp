// firmware/cortex-m/replay_format.hpp -- the files the Cortex-M replay exchanges with the host
// (replay.cpp on the target, host_check.cpp on the host; little-endian at both ends).
//
//   motion.bin          MotionHeader, then n_steps + 1 MotionSample (sample 0 is the reset,
//                       step k uses sample k); segment_end[] splits the steps into the
//                       segments the firmware measures one by one
//   <variant>.out.bin   n_steps + 1 OutputRecord (record 0: the reset's status)
#pragma once

#include <cstdint>

namespace fw {

constexpr int max_segments = 8;

struct MotionHeader {
  char magic[8];  // "IMOTION1"
  std::uint32_t n_steps;
  std::uint32_t n_segments;
  std::uint32_t segment_end[max_segments];  // exclusive sample index where each segment ends
};

struct MotionSample {
  double angle_rad;
  double rate_radps;
  double airspeed_mps;
  double dt_s;
};

struct OutputRecord {
  std::int32_t status;  // indicial::StepStatus
  float value[3];       // the model's coefficients first (at most 3, Capacity's limit)
};

}  // namespace fw
