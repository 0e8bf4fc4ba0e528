#!/usr/bin/env bash
# The runtime on a Cortex-M4F under QEMU (firmware/cortex-m/README.md): builds the replay
# firmware four ways (codegen_state, codegen_predictor, coef_text: Model II; stall_state: Model
# II with every dynamic-stall family on C_L and C_m) with Debian's arm-none-eabi GCC and
# newlib, proves that the link refuses malloc/free/new (a planted reference must fail to
# link), runs each image on `qemu-system-arm -M mps2-an386` with
# semihosting and -icount shift=0, compares every step with the host's float build (bit for
# bit) and double build, and reports instructions per step, flash, RAM and stack.
#
#   tools/run-cortex-m.sh            # build/ must hold (or will get) the `indicial` tool
#
# Environment: INDICIAL_BUILD_DIR (the host build with tools/indicial, default build; the
# `indicial` target is built there if missing), INDICIAL_CORTEX_M_DIR (output, default
# build-cortex-m). Writes there: *.elf, *.map, *.summary.txt, *.compare.txt, footprint.md (the
# table that bench/RESULTS.md's Cortex-M section quotes). Exit status 1 on any mismatch or failed check.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build_dir=${INDICIAL_BUILD_DIR:-build}
out=${INDICIAL_CORTEX_M_DIR:-build-cortex-m}
fw=firmware/cortex-m
model_coef=$fw/model2-cl-cm.coef
stall_coef=$fw/stall2-cl-cm.coef

# The cross compiler, newlib, libstdc++ for newlib, QEMU: the cortex-m extra of
# tools/install-deps.sh (installed only if missing).
tools/install-deps.sh cortex-m
for tool in arm-none-eabi-g++ arm-none-eabi-size arm-none-eabi-objdump qemu-system-arm python3; do
  command -v "$tool" >/dev/null || { echo "run-cortex-m: $tool not found (tools/install-deps.sh cortex-m)" >&2; exit 2; }
done
start=$(date +%s)

indicial=$build_dir/tools/indicial
if [ ! -x "$indicial" ]; then
  [ -f "$build_dir/CMakeCache.txt" ] || cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release
  cmake --build "$build_dir" --target indicial -j"$(nproc)"
fi
mkdir -p "$out"

# ---- host side: the reference motion and the comparison program ------------------------------
c++ -std=c++17 -O2 -ffp-contract=off -Wall -Wextra -Iruntime/include -Ishared/include \
  "$fw/host_check.cpp" -o "$out/host_check"
"$out/host_check" motion "$out/motion.bin"

# ---- the two model inputs: the generated float model and the .coef text -------------------------
"$indicial" codegen "$model_coef" --scalar float --capacity tight --name firmware_model \
  --out "$out/generated_model.hpp" --force
"$indicial" codegen "$stall_coef" --scalar float --capacity tight --name firmware_model \
  --out "$out/generated_stall_model.hpp" --force
{ printf 'R"coef('; cat "$model_coef"; printf ')coef"\n'; } > "$out/model_text.inc"

# ---- cross build ------------------------------------------------------------------------------
# -ffp-contract=off: the FPv4 has fused multiply-add, x86-64 without -mfma has not; contracting
# a * b + c on one side only would change the last bit (the host build does not contract).
# -Wno-array-bounds: with the tight capacity and the model a constant inlined everywhere,
# GCC 12 warns about paths the model's counts never take (lag 1 of a one-lag capacity, row
# i + 1 of a two-row table: the loops stop at n_lags and n_table).
cflags=(-mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard -mthumb -O2 -std=c++17
        -fno-exceptions -fno-rtti -fno-threadsafe-statics -ffp-contract=off
        -ffunction-sections -fdata-sections -Wall -Wextra -Werror -Wno-array-bounds
        -I"$out" -I"$fw" -Iruntime/include -Ishared/include)
# The heap is refused at link time: every allocation entry point of newlib (malloc & co and
# their reentrant _r forms) and of libstdc++ (operator new / delete, arrays, sized) is
# wrapped, and no __wrap_ symbol exists, so any reference names itself in a link error.
heap_symbols=(malloc free calloc realloc _malloc_r _free_r _calloc_r _realloc_r memalign
              _memalign_r _Znwj _Znaj _ZdlPv _ZdaPv _ZdlPvj _ZdaPvj _ZnwjRKSt9nothrow_t
              _ZnajRKSt9nothrow_t)
wrap=$(printf -- '--wrap=%s,' "${heap_symbols[@]}")
ldflags=(-nostartfiles -T "$fw/mps2-an386.ld" -Wl,--gc-sections "-Wl,${wrap%,}")

compile_variant() {  # name number [extra flags...]
  local name=$1 number=$2
  shift 2
  arm-none-eabi-g++ "${cflags[@]}" -DINDICIAL_FW_VARIANT="$number" "$@" -c "$fw/replay.cpp" -o "$out/$name.o"
}
arm-none-eabi-g++ "${cflags[@]}" -c "$fw/startup.cpp" -o "$out/startup.o"

# The check must be able to fail: a planted malloc and new must not link.
compile_variant planted_heap 1 -DINDICIAL_FW_PLANT_HEAP
if arm-none-eabi-g++ "${cflags[@]}" "${ldflags[@]}" "$out/planted_heap.o" "$out/startup.o" \
    -o "$out/planted_heap.elf" 2> "$out/planted_heap.log"; then
  echo "run-cortex-m: FAILED: a firmware calling malloc and new linked (the heap check is broken)" >&2
  exit 1
fi
if ! grep -q "undefined reference to \`__wrap_malloc'" "$out/planted_heap.log" ||
   ! grep -q "undefined reference to \`__wrap__Znwj'" "$out/planted_heap.log"; then
  echo "run-cortex-m: FAILED: the planted heap reference failed to link for another reason:" >&2
  cat "$out/planted_heap.log" >&2
  exit 1
fi
echo "run-cortex-m: the planted malloc and new are refused at link time (as they must be)"

variants=(codegen_state codegen_predictor coef_text stall_state)
variant_coef=("$model_coef" "$model_coef" "$model_coef" "$stall_coef")
failed=()
for i in 0 1 2 3; do
  name=${variants[$i]}
  compile_variant "$name" $((i + 1))
  arm-none-eabi-g++ "${cflags[@]}" "${ldflags[@]}" "-Wl,-Map=$out/$name.map" "$out/$name.o" \
    "$out/startup.o" -o "$out/$name.elf"
  rm -f "$out/$name.summary.txt" "$out/$name.out.bin"
  # -icount shift=0: the virtual clock advances 1 ns per instruction (instruction_counter.hpp).
  (cd "$out" && timeout 120 qemu-system-arm -M mps2-an386 -cpu cortex-m4 -nographic -monitor none \
     -serial none -semihosting-config enable=on,target=native -icount shift=0 -kernel "$name.elf") ||
    { echo "run-cortex-m: $name: the firmware failed under QEMU" >&2; failed+=("$name"); continue; }
  echo "=== $name: target vs host"
  "$out/host_check" compare "${variant_coef[$i]}" "$out/motion.bin" "$out/$name.out.bin" --max-ulp 0 \
    > "$out/$name.compare.txt" || failed+=("$name")
  cat "$out/$name.compare.txt"
done
[ ${#failed[@]} -eq 0 ] || { echo "run-cortex-m: FAILED: ${failed[*]}" >&2; exit 1; }

python3 "$fw/footprint.py" "$out" "${variants[@]}" > "$out/footprint.md"
cat "$out/footprint.md"
echo "run-cortex-m: all variants bit-identical to the host float build ($(( $(date +%s) - start )) s)"
