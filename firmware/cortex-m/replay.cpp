// firmware/cortex-m/replay.cpp -- the runtime on a Cortex-M4F: replays a reference motion
// through Predictor<float> (or the stateless State<float> core) under QEMU and reports, by
// semihosting, every step's status and outputs, the instructions per step, the stack a step
// uses and the sizes of the runtime's objects. tools/run-cortex-m.sh builds it four times:
//
//   INDICIAL_FW_VARIANT=1  codegen_state      the model from `indicial codegen --scalar float`
//                                             (read-only memory), a State<float> stepped by
//                                             indicial::step: the smallest embedding, the one
//                                             the footprint goals are measured on
//   INDICIAL_FW_VARIANT=2  codegen_predictor  the same model through Predictor<float>::use
//   INDICIAL_FW_VARIANT=3  coef_text          Predictor<float>::load(text) parses the .coef
//                                             text (coef_file.hpp) on the target
//   INDICIAL_FW_VARIANT=4  stall_state        as codegen_state, with stall2-cl-cm.coef (every
//                                             dynamic-stall family on C_L and C_m) generated
//                                             into generated_stall_model.hpp, stepped on a
//                                             FamilyState<float>
//
// Files (host paths, relative to QEMU's working directory): motion.bin in (written by
// firmware/cortex-m/host_check.cpp), <variant>.out.bin and <variant>.summary.txt out. The
// formats are host_check.cpp's (little-endian, as both ends are).
//
// Nothing here allocates: the link refuses malloc, free and operator new
// (tools/run-cortex-m.sh, --wrap), and newlib's stdio is not linked (semihosting.hpp).
#include <cstddef>
#include <cstdint>

#include "instruction_counter.hpp"
#include "replay_format.hpp"
#include "semihosting.hpp"

#if INDICIAL_FW_VARIANT == 3
#include "indicial/coef_file.hpp"
#elif INDICIAL_FW_VARIANT == 4
#include "generated_stall_model.hpp"  // the same, from stall2-cl-cm.coef
#else
#include "generated_model.hpp"  // indicial codegen --scalar float --capacity tight --name firmware_model
#endif
#include "indicial/runtime.hpp"

#if defined(INDICIAL_FW_PLANT_HEAP)
#include <cstdlib>
#endif

// The stateless core (indicial::step on a model used in place) or the Predictor.
#define FW_STATE_CORE (INDICIAL_FW_VARIANT == 1 || INDICIAL_FW_VARIANT == 4)

namespace {

// The generated model carries the smallest Capacity that holds it (codegen --capacity tight);
// the parser takes any file up to DefaultCapacity.
#if INDICIAL_FW_VARIANT == 3
using Cap = indicial::DefaultCapacity;
#else
using Cap = indicial_generated::firmware_model_capacity;
#endif
using Model = indicial::RuntimeModel<float, Cap>;

#if INDICIAL_FW_VARIANT == 1
constexpr const char* variant_name = "codegen_state";
#elif INDICIAL_FW_VARIANT == 2
constexpr const char* variant_name = "codegen_predictor";
#elif INDICIAL_FW_VARIANT == 3
constexpr const char* variant_name = "coef_text";
const char model_text[] =
#include "model_text.inc"
    ;
#elif INDICIAL_FW_VARIANT == 4
constexpr const char* variant_name = "stall_state";
#else
#error "INDICIAL_FW_VARIANT must be 1 (codegen_state), 2 (codegen_predictor), 3 (coef_text) or 4 (stall_state)"
#endif

// ---- the replay files (replay_format.hpp) ----------------------------------------------------
constexpr int max_steps = 4096;
using fw::MotionHeader;
using fw::MotionSample;
using fw::OutputRecord;

// The harness's buffers, kept in their own section (.replay): not part of the runtime's RAM.
__attribute__((section(".replay"))) MotionHeader header;
__attribute__((section(".replay"))) MotionSample motion[max_steps + 1];
__attribute__((section(".replay"))) OutputRecord output[max_steps + 1];

// ---- the runtime under test -----------------------------------------------------------------
#if INDICIAL_FW_VARIANT == 1
constexpr const Model& model = indicial_generated::firmware_model;  // in flash, used in place
indicial::State<float, Cap> state;
#elif INDICIAL_FW_VARIANT == 4
constexpr const Model& model = indicial_generated::firmware_model;
indicial::FamilyState<float, Cap> state;  // the State plus each coefficient's f, v, tau_v
#else
indicial::Predictor<float, Cap> predictor;
#endif

// The one-time calls are flattened (GCC inlines everything they call) in the codegen variants:
// with the model a compile-time constant the compiler then drops the paths its axis never
// takes (a pitch model: the roll/yaw trigonometry of the model angle and of the axis factor
// that check_runtime_model recomputes, about 9 KB of newlib's libm). The step itself is
// inlined into step_once anyway. The coef_text variant's model is known only at run time.
// (noinline: their code stays in their own symbols, counted as the runtime's flash, not main's.)
#if INDICIAL_FW_VARIANT == 3
#define FW_ONE_TIME_CALL __attribute__((noinline))
#else
#define FW_ONE_TIME_CALL __attribute__((flatten, noinline))
#endif

FW_ONE_TIME_CALL indicial::StepStatus load_model() {
#if FW_STATE_CORE
  return indicial::check_runtime_model(model) == indicial::LoadStatus::ok
             ? indicial::StepStatus::ok
             : indicial::StepStatus::not_loaded;
#elif INDICIAL_FW_VARIANT == 2
  return predictor.use(indicial_generated::firmware_model) == indicial::LoadStatus::ok
             ? indicial::StepStatus::ok
             : indicial::StepStatus::not_loaded;
#else
  return predictor.load(model_text, sizeof model_text - 1) == indicial::LoadStatus::ok
             ? indicial::StepStatus::ok
             : indicial::StepStatus::not_loaded;
#endif
}

FW_ONE_TIME_CALL indicial::StepStatus reset_model(const MotionSample& s) {
#if FW_STATE_CORE
  return indicial::reset(model, state, s.angle_rad, s.airspeed_mps);
#else
  return predictor.reset(s.angle_rad, s.airspeed_mps);
#endif
}

int coefficient_count() {
#if FW_STATE_CORE
  return model.set.n_coefficients;
#else
  return predictor.coefficient_count();
#endif
}

// One step, out of line so that its instructions are counted apart from the loop's; flattened
// like the one-time calls (the constant model's unused paths -- the dynamic-stall families of a
// model without them -- fold away).
FW_ONE_TIME_CALL std::int32_t step_once(const MotionSample& s, OutputRecord* r) {
  const indicial::MotionInput in{s.angle_rad, s.rate_radps, s.airspeed_mps};
#if FW_STATE_CORE
  return static_cast<std::int32_t>(indicial::step(model, state, in, s.dt_s, r->value));
#else
  indicial::Predictor<float, Cap>::Outputs out;
  const indicial::StepStatus st = predictor.step(in, s.dt_s, &out);
  for (int c = 0; c < Cap::max_coefficients; ++c) r->value[c] = out.value[c];
  return static_cast<std::int32_t>(st);
#endif
}

// The same call with nothing in it: the loop's own instructions, subtracted.
__attribute__((noinline)) std::int32_t step_empty(const MotionSample&, OutputRecord*) {
  asm volatile("" ::: "memory");
  return 0;
}

// ---- stack high-water mark -----------------------------------------------------------------
// The words below the current stack pointer are filled with a pattern; afterwards the lowest
// word that changed is the deepest the stack went. Deterministic (no interrupts run).
constexpr std::uint32_t stack_pattern = 0x5AA5C33Cu;
constexpr std::uint32_t step_painted_bytes = 16384;
constexpr std::uint32_t load_painted_bytes = 49152;  // the parser keeps ModelSets on the stack

inline std::uint32_t stack_pointer() {
  std::uint32_t sp;
  asm volatile("mov %0, sp" : "=r"(sp));
  return sp;
}

__attribute__((noinline)) std::uint32_t paint_stack(std::uint32_t painted_bytes) {
  const std::uint32_t sp = stack_pointer();
  volatile std::uint32_t* p = reinterpret_cast<volatile std::uint32_t*>(sp - painted_bytes);
  volatile std::uint32_t* const top = reinterpret_cast<volatile std::uint32_t*>(sp - 64);
  while (p < top) *p++ = stack_pattern;
  return sp - painted_bytes;
}

std::uint32_t deepest_touched(std::uint32_t painted_bottom) {
  const volatile std::uint32_t* p = reinterpret_cast<const volatile std::uint32_t*>(painted_bottom);
  while (*p == stack_pattern) ++p;
  return reinterpret_cast<std::uint32_t>(p);
}

// ---- measured windows --------------------------------------------------------------------
using StepFunction = std::int32_t (*)(const MotionSample&, OutputRecord*);

struct Window {
  std::uint32_t ticks;
  std::uint32_t call_sp;  // the stack pointer at the step calls
};

__attribute__((noinline)) Window run_steps(StepFunction f, int begin, int end) {
  Window w{};
  w.call_sp = stack_pointer();
  const std::uint32_t t0 = fw::counter_ticks();
  for (int k = begin; k < end; ++k) output[k].status = f(motion[k], &output[k]);
  w.ticks = fw::ticks_between(t0, fw::counter_ticks());
  return w;
}

// Loops of known length (2 and 4 instructions per iteration, the second with a float divide
// and square root that take 14 cycles each on a real Cortex-M4): the method's cross-check.
__attribute__((noinline)) void known_loop_2(std::uint32_t n) {
  asm volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n) : : "cc");
}
__attribute__((noinline)) void known_loop_4(std::uint32_t n) {
  asm volatile(
      "vmov.f32 s0, #1.0\n\tvmov.f32 s1, #2.0\n"
      "1: vdiv.f32 s2, s0, s1\n\tvsqrt.f32 s3, s1\n\tsubs %0, %0, #1\n\tbne 1b"
      : "+r"(n)
      :
      : "cc", "s0", "s1", "s2", "s3");
}

template <class F>
std::uint32_t ticks_of(F f) {
  const std::uint32_t t0 = fw::counter_ticks();
  f();
  return fw::ticks_between(t0, fw::counter_ticks());
}

// ---- the summary (key value lines, integers only) ------------------------------------------
struct Text {
  char buffer[4096];
  std::size_t n = 0;
  void add(const char* s) {
    while (*s != '\0' && n + 1 < sizeof buffer) buffer[n++] = *s++;
  }
  void add(std::uint32_t v) {
    char digits[12];
    int i = 0;
    do {
      digits[i++] = static_cast<char>('0' + v % 10);
      v /= 10;
    } while (v != 0);
    while (i > 0 && n + 1 < sizeof buffer) buffer[n++] = digits[--i];
  }
  void line(const char* key, std::uint32_t v) {
    add(key);
    add(" ");
    add(v);
    add("\n");
  }
};
Text summary;

bool write_whole(const char* path, const void* data, std::size_t n) {
  const std::int32_t h = fw::open_file(path, fw::OpenMode::write_binary);
  if (h < 0) return false;
  const bool ok = fw::write_file(h, data, n) == 0;
  fw::close_file(h);
  return ok;
}

bool read_motion() {
  const std::int32_t h = fw::open_file("motion.bin", fw::OpenMode::read_binary);
  if (h < 0) return false;
  bool ok = fw::read_file(h, &header, sizeof header) == 0;
  const char magic[8] = {'I', 'M', 'O', 'T', 'I', 'O', 'N', '1'};
  for (int i = 0; i < 8; ++i) ok = ok && header.magic[i] == magic[i];
  ok = ok && header.n_steps >= 1 && header.n_steps <= max_steps && header.n_segments >= 1 &&
       header.n_segments <= fw::max_segments && header.segment_end[header.n_segments - 1] == header.n_steps + 1;
  ok = ok && fw::read_file(h, motion, (header.n_steps + 1) * sizeof(MotionSample)) == 0;
  fw::close_file(h);
  return ok;
}

void measure_known_loops() {
  summary.line("known_loop_2_iterations", 100000);
  summary.line("known_loop_2_ticks", ticks_of([] { known_loop_2(100000); }));
  summary.line("known_loop_4_iterations", 100000);
  summary.line("known_loop_4_ticks", ticks_of([] { known_loop_4(100000); }));
  summary.line("empty_window_ticks", ticks_of([] {}));
}

void record_sizes() {
  summary.line("sizeof_state", sizeof(indicial::State<float, Cap>));
  summary.line("sizeof_family_state", sizeof(indicial::FamilyState<float, Cap>));
  summary.line("sizeof_delayed_state", sizeof(indicial::DelayedState<float, Cap>));
  summary.line("sizeof_predictor", sizeof(indicial::Predictor<float, Cap>));
  summary.line("sizeof_runtime_model", sizeof(Model));
}

// The replay, segment by segment: each segment is run once with the empty function (which
// changes nothing) and once with the step; the difference of the two windows is the steps'
// instructions. The stack high-water mark is taken over each segment's steps.
void replay() {
  int begin = 1;
  for (std::uint32_t seg = 0; seg < header.n_segments; ++seg) {
    const int end = static_cast<int>(header.segment_end[seg]);
    // The empty run first: it writes the statuses (0) that the run with the step overwrites.
    const Window empty = run_steps(&step_empty, begin, end);
    const std::uint32_t painted = paint_stack(step_painted_bytes);
    const Window with_step = run_steps(&step_once, begin, end);
    const std::uint32_t deepest = deepest_touched(painted);
    summary.add("segment ");
    summary.add(seg);
    summary.add(" steps ");
    summary.add(static_cast<std::uint32_t>(end - begin));
    summary.add(" step_ticks ");
    summary.add(with_step.ticks);
    summary.add(" empty_ticks ");
    summary.add(empty.ticks);
    summary.add(" stack_bytes ");
    summary.add(with_step.call_sp - deepest);
    summary.add("\n");
    begin = end;
  }
}

}  // namespace

int main() {
  fw::start_counter();
#if defined(INDICIAL_FW_PLANT_HEAP)
  // tools/run-cortex-m.sh builds this once to prove that the link refuses the heap.
  // (Both pointers escape into the summary, so the compiler cannot elide the allocations.)
  void* planted = std::malloc(16);
  summary.line("planted_malloc", reinterpret_cast<std::uint32_t>(planted));
  int* planted_new = new int(1);
  summary.line("planted_new", reinterpret_cast<std::uint32_t>(planted_new));
#endif
  summary.add("variant ");
  summary.add(variant_name);
  summary.add("\n");
  measure_known_loops();
  record_sizes();
  if (!read_motion()) {
    fw::print("firmware: cannot read motion.bin (see host_check.cpp for its format)\n");
    return 2;
  }
  const std::uint32_t painted = paint_stack(load_painted_bytes);
  const std::uint32_t sp_at_load = stack_pointer();
  const std::uint32_t t_load = fw::counter_ticks();
  const indicial::StepStatus loaded = load_model();
  summary.line("load_ticks", fw::ticks_between(t_load, fw::counter_ticks()));
  summary.line("load_stack_bytes", sp_at_load - deepest_touched(painted));
  if (loaded != indicial::StepStatus::ok) {
    fw::print("firmware: the model was refused\n");
    return 2;
  }
  summary.line("coefficients", static_cast<std::uint32_t>(coefficient_count()));
  for (std::uint32_t k = 0; k <= header.n_steps; ++k) output[k] = OutputRecord{};
  output[0].status = static_cast<std::int32_t>(reset_model(motion[0]));
  replay();
  char out_path[64] = {};
  char summary_path[64] = {};
  std::size_t i = 0;
  for (const char* s = variant_name; *s != '\0'; ++s, ++i) out_path[i] = summary_path[i] = *s;
  const char out_suffix[] = ".out.bin";
  const char summary_suffix[] = ".summary.txt";
  for (std::size_t k = 0; k < sizeof out_suffix; ++k) out_path[i + k] = out_suffix[k];
  for (std::size_t k = 0; k < sizeof summary_suffix; ++k) summary_path[i + k] = summary_suffix[k];
  if (!write_whole(out_path, output, (header.n_steps + 1) * sizeof(OutputRecord)) ||
      !write_whole(summary_path, summary.buffer, summary.n)) {
    fw::print("firmware: cannot write the results\n");
    return 2;
  }
  return 0;
}
