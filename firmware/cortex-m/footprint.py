#!/usr/bin/env python3
"""firmware/cortex-m/footprint.py -- the Cortex-M figures of tools/run-cortex-m.sh, as Markdown.

    footprint.py OUT_DIR VARIANT...

Reads, for each variant, OUT_DIR/VARIANT.summary.txt (written by the firmware under QEMU),
VARIANT.elf (sizes of sections and symbols, arm-none-eabi-size / nm), its disassembly
(stack_depth.py) and VARIANT.compare.txt (host_check compare's lines: target vs host float and
double), and prints the table and comparisons bench/RESULTS.md quotes. Fails (exit 1) when the
instruction counter does not count the known loops right (the method is then broken).

Instructions: under `-icount shift=0` one SysTick tick (25 MHz) is 40 instructions
(instruction_counter.hpp); per step = (ticks of the segment with the step - ticks of the same
loop calling an empty function) * 40 / steps, +-80 / steps.

Flash = every section loaded into the code memory (.text with .rodata, the exception index,
.init_array, .data's initial values); RAM = .data + .bss (the .replay buffers of the harness
are not counted). "runtime + model" leaves out the harness's own symbols (HARNESS below: the
replay loop, semihosting, the counters, the summary buffer, the vector table); the runtime's
code inlined into the harness's step_once / load_model stays counted as runtime.
"""
import os
import re
import subprocess
import sys

NS_PER_TICK = 40  # 25 MHz SysTick; -icount shift=0: 1 ns per instruction
HARNESS = re.compile(
    r"^(main|reset_handler|fault_handler|vector_table|abort|__gxx_personality_v0|fw::.*|"
    r"\(anonymous namespace\)::(summary|paint_stack|deepest_touched|run_steps|"
    r"step_empty|known_loop_\d|measure_known_loops|record_sizes|replay|read_motion|write_whole|"
    r"Text::.*|ticks_of.*|.*lambda.*))")
FLASH_SECTIONS = re.compile(r"^(\.text|\.ARM\.ex(idx|tab).*|\.init_array|\.data)$")


def read_summary(path):
    values, segments = {}, []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] == "segment":
                segments.append(dict(zip(parts[0::2], (int(p) for p in parts[1::2]))))
            elif len(parts) == 2:
                values[parts[0]] = int(parts[1]) if parts[1].isdigit() else parts[1]
    return values, segments


def sections(elf):
    text = subprocess.run(["arm-none-eabi-size", "-A", elf], capture_output=True, text=True,
                          check=True).stdout
    result = {}
    for line in text.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0].startswith(".") and parts[1].isdigit():
            result[parts[0]] = int(parts[1])
    return result


def symbols(elf):
    text = subprocess.run(["arm-none-eabi-nm", "-S", "-C", elf], capture_output=True, text=True,
                          check=True).stdout
    result = []
    for line in text.splitlines():
        m = re.match(r"^([0-9a-f]+) ([0-9a-f]+) (\w) (.*)$", line)
        if m:
            result.append((int(m.group(1), 16), int(m.group(2), 16), m.group(3), m.group(4)))
    return result


def static_stack(elf, fw_dir):
    dis = subprocess.run(["arm-none-eabi-objdump", "-d", "--no-show-raw-insn", elf],
                         capture_output=True, text=True, check=True).stdout
    out = subprocess.run([sys.executable, os.path.join(fw_dir, "stack_depth.py"), "step_once"],
                         input=dis, capture_output=True, text=True, check=True).stdout
    chain = out.strip().splitlines()
    total = int(re.search(r"(\d+) bytes", chain[-1]).group(1))
    return total, chain[:-1]


def read_compare(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return [line.rstrip() for line in f if line.strip()]


def per_step(segment):
    return (segment["step_ticks"] - segment["empty_ticks"]) * NS_PER_TICK / segment["steps"]


def check_counter(values, name):
    for loop, per_iteration in (("known_loop_2", 2), ("known_loop_4", 4)):
        expected = per_iteration * values[loop + "_iterations"]
        counted = values[loop + "_ticks"] * NS_PER_TICK
        if abs(counted - expected) > 2 * NS_PER_TICK:
            sys.exit(f"footprint: {name}: {loop} counted {counted} instructions, expected {expected}: "
                     "the -icount method is broken")


def describe(out_dir, name, fw_dir):
    values, segments = read_summary(os.path.join(out_dir, name + ".summary.txt"))
    check_counter(values, name)
    elf = os.path.join(out_dir, name + ".elf")
    sec = sections(elf)
    flash = sum(size for s, size in sec.items() if FLASH_SECTIONS.match(s))
    ram = sec.get(".data", 0) + sec.get(".bss", 0)
    harness_flash = harness_ram = model = 0
    for address, size, kind, sym in symbols(elf):
        in_ram = address >= 0x20000000
        if sym.startswith("indicial_generated::") or sym.endswith("::model_text"):
            model += size
        if HARNESS.match(sym):
            if in_ram:
                harness_ram += size
                if kind in "dD":  # initialised data also occupies flash
                    harness_flash += size
            else:
                harness_flash += size
    stack_bound, chain = static_stack(elf, fw_dir)
    return {
        "name": name,
        "steps0": per_step(segments[0]),
        "steps1": per_step(segments[1]),
        "resolution": 2 * NS_PER_TICK / segments[0]["steps"],
        "flash": flash,
        "flash_runtime": flash - harness_flash,
        "model": model,
        "ram": ram,
        "ram_runtime": ram - harness_ram,
        "state": values["sizeof_state"],
        "family_state": values.get("sizeof_family_state"),
        "compare": read_compare(os.path.join(out_dir, name + ".compare.txt")),
        "predictor": values["sizeof_predictor"],
        "stack_measured": max(s["stack_bytes"] for s in segments),
        "stack_bound": stack_bound,
        "chain": chain,
        "load": values["load_ticks"] * NS_PER_TICK,
        "load_stack": values["load_stack_bytes"],
    }


def main():
    out_dir, names = sys.argv[1], sys.argv[2:]
    fw_dir = os.path.dirname(os.path.abspath(__file__))
    rows = [describe(out_dir, n, fw_dir) for n in names]
    print("| variant | instructions/step, bench motion | instructions/step, clamps + airspeed changes "
          "| flash, whole image | flash, runtime + model | of which model | RAM (.data + .bss), runtime "
          "| stack/step, measured | stack/step, static bound | load/check instructions | load/check stack |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['name']} | {r['steps0']:.1f} | {r['steps1']:.1f} | {r['flash']} | {r['flash_runtime']} "
              f"| {r['model']} | {r['ram_runtime']} | {r['stack_measured']} | {r['stack_bound']} "
              f"| {r['load']} | {r['load_stack']} |")
    r = rows[0]
    print()
    print(f"Counts +-{r['resolution']:.2f} instructions/step (one 40-instruction tick at each end of a "
          f"{int(2 * NS_PER_TICK / r['resolution'])}-step window). State per instance: "
          f"State<float> {r['state']} B; Predictor<float> {r['predictor']} B (its own model copy and "
          "the delay ring included).", end="")
    stall = [x for x in rows if x["name"].startswith("stall")]
    if stall and stall[0]["family_state"]:
        print(f" FamilyState<float> {stall[0]['family_state']} B ({stall[0]['name']}: the State plus each "
              "coefficient's f, v and tau_v).")
    else:
        print()
    print()
    print("Every step against the host (`host_check compare`: the target's float outputs against the "
          "host's `Predictor<float>` and `Predictor<double>` on the same motion; relative to "
          "max(|value|, 0.01)):")
    print()
    print("| variant | steps compared | statuses differ | target vs host float | target vs host double, "
          "max abs | max rel | host float vs host double, max abs |")
    print("|---|---|---|---|---|---|---|")
    for x in rows:
        c = " ".join(x["compare"])
        m = re.search(r"steps compared: (\d+) \((\d+) statuses differ\).*max (\d+) ulp.*"
                      r"host double: max abs (\S+), max rel (\S+) .*host float vs host double: max abs (\S+)", c)
        if m:
            print(f"| {x['name']} | {m.group(1)} | {m.group(2)} | {m.group(3)} ulp | {m.group(4)} | "
                  f"{m.group(5)} | {m.group(6)} |")
    print()
    print(f"Deepest static call chain of one step ({r['name']}; frame bytes, function):")
    print()
    for line in r["chain"]:
        print("    " + line)


if __name__ == "__main__":
    main()
