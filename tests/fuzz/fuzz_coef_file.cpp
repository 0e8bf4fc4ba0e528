// tests/fuzz/fuzz_coef_file.cpp -- libFuzzer target: the coefficient-file parser
// (runtime/include/indicial/coef_file.hpp) and Predictor::load on any byte string.
//
// The first input byte is a mode byte: odd means "give the rest a correct checksum" (any final
// `checksum` line is dropped and the right one appended), so the fuzzer gets past the CRC and
// explores the grammar; even means "parse the rest as it is" (corrupted files). Properties:
//  1. parse_coef_file returns a status for any bytes, reads none past the end (the input is an
//     exact-size heap copy, so ASan would see it), and leaves *out byte-for-byte untouched on
//     refusal with a non-empty reason;
//  2. an accepted file writes back (write_coef_file ok) and write -> parse -> write is
//     byte-identical;
//  3. Predictor::load refuses or accepts without crashing; once loaded, reset and step give
//     finite outputs whenever they report ok or angle_clamped.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "fuzz_common.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"

namespace {

using Cap = indicial::DefaultCapacity;
using Set = indicial::ModelSet<double, Cap>;
using indicial_fuzz::fuzz_fail;

std::string with_correct_checksum(std::string text) {
  const std::size_t at = text.rfind("checksum ");
  if (at != std::string::npos && (at == 0 || text[at - 1] == '\n')) text.resize(at);
  if (!text.empty() && text.back() != '\n') text += '\n';
  char line[32];
  std::snprintf(line, sizeof line, "checksum %08x\n",
                static_cast<unsigned>(indicial::crc32(text.data(), text.size())));
  return text + line;
}

indicial::LoadStatus parse_exact(const std::string& text, Set* out,
                                 indicial::ParseDiagnostic* diag) {
  // An exact-size heap block: one byte read past the end is an ASan report.
  std::unique_ptr<char[]> copy(new char[text.size() + (text.empty() ? 1 : 0)]);
  std::memcpy(copy.get(), text.data(), text.size());
  return indicial::parse_coef_file(text.empty() ? nullptr : copy.get(), text.size(), out, diag);
}

void check_predictor(const std::string& text, std::uint8_t salt) {
  static indicial::Predictor<double> p;  // ~23 KB: static, not on the fuzzer's stack per input
  p = indicial::Predictor<double>{};
  indicial::ParseDiagnostic diag;
  const indicial::LoadStatus s = p.load(text.data(), text.size(), &diag);
  if (s != indicial::LoadStatus::ok) {
    if (diag.reason == nullptr || diag.reason[0] == '\0') fuzz_fail("load refused without a reason");
    if (p.phase() != indicial::PredictorPhase::empty) fuzz_fail("refused load changed the phase");
    return;
  }
  const auto& m = p.model();
  const double lo = m.x_min_rad, hi = m.x_max_rad;
  const double angles[5] = {lo, hi, 0.5 * (lo + hi), lo - 1.0, hi + 1.0};
  indicial::Predictor<double>::Outputs out;
  for (int r = 0; r < 2; ++r) {
    const double a0 = angles[(salt + r) % 5];
    const indicial::StepStatus rs = p.reset(a0, m.airspeed_mps);
    if (rs != indicial::StepStatus::ok && rs != indicial::StepStatus::angle_clamped &&
        rs != indicial::StepStatus::non_finite_result)
      fuzz_fail("reset: unexpected status", indicial::to_string(rs));
    if (rs == indicial::StepStatus::non_finite_result) continue;
    for (int k = 0; k < 40; ++k) {
      const indicial::MotionInput in{angles[(salt + k) % 5] + 0.01 * k, 2.0 * std::sin(0.3 * k),
                                     m.airspeed_mps * (0.5 + 0.05 * k)};
      const indicial::StepStatus ss = p.step(in, 0.001 * (1 + k % 7), &out);
      if (ss == indicial::StepStatus::ok || ss == indicial::StepStatus::angle_clamped) {
        for (int c = 0; c < out.count; ++c)
          if (!std::isfinite(out.value[c])) fuzz_fail("step reported ok with a non-finite output");
      } else if (ss != indicial::StepStatus::non_finite_result) {
        fuzz_fail("step: unexpected status", indicial::to_string(ss));
      }
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Set model, before, again;
  std::string text;
  if (size > 0) {
    text.assign(reinterpret_cast<const char*>(data + 1), size - 1);
    if ((data[0] & 1u) != 0) text = with_correct_checksum(text);
  }

  // 1. Parse; on refusal *out is untouched (fill it with a pattern first).
  std::memset(static_cast<void*>(&model), 0xA5, sizeof model);
  std::memcpy(static_cast<void*>(&before), static_cast<const void*>(&model), sizeof model);
  indicial::ParseDiagnostic diag;
  const indicial::LoadStatus s = parse_exact(text, &model, &diag);
  if (s != indicial::LoadStatus::ok) {
    if (diag.reason == nullptr || diag.reason[0] == '\0') fuzz_fail("refused without a reason");
    if (std::strlen(indicial::to_string(s)) == 0) fuzz_fail("status has no name");
    if (std::memcmp(&model, &before, sizeof model) != 0) fuzz_fail("refusal changed *out");
    return 0;
  }

  // 2. Write back; write -> parse -> write is byte-identical.
  static char buffer1[1 << 16], buffer2[1 << 16];
  std::size_t n1 = 0, n2 = 0;
  indicial::WriteStatus w = indicial::write_coef_file(model, buffer1, sizeof buffer1, &n1);
  if (w != indicial::WriteStatus::ok) fuzz_fail("accepted model does not write", indicial::to_string(w));
  const std::string written(buffer1, n1);
  const indicial::LoadStatus s2 = parse_exact(written, &again, &diag);
  if (s2 != indicial::LoadStatus::ok)
    fuzz_fail("written file does not parse", std::string(indicial::to_string(s2)) + ": " + diag.reason);
  w = indicial::write_coef_file(again, buffer2, sizeof buffer2, &n2);
  if (w != indicial::WriteStatus::ok || n1 != n2 || std::memcmp(buffer1, buffer2, n1) != 0)
    fuzz_fail("write -> parse -> write is not byte-identical");

  // 3. The runtime on the accepted text.
  check_predictor(text, size > 1 ? data[1] : 0);
  return 0;
}
