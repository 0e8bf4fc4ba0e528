#!/usr/bin/env python3
"""firmware/cortex-m/stack_depth.py -- worst-case stack of a call, from the linked firmware.

    arm-none-eabi-objdump -d --no-show-raw-insn replay.elf | stack_depth.py step_once

Walks the static call graph of the final image (every `bl` and tail-call branch to another
function) from the first function whose name contains the given text, and adds up each
function's frame: the bytes of its push / stmdb sp! / vpush and sub sp, #N instructions (all of
them, on every path: an upper bound when a function saves registers on one path only). Library
functions (libm, libgcc) are walked the same way, so the bound covers them too, which GCC's
-fstack-usage / -fcallgraph-info cannot (they see only what this build compiled). Fails on
recursion and on an indirect call (blx rN), where no static bound exists. Prints the deepest
chain (demangled by arm-none-eabi-c++filt) and the bound in bytes. Reads the disassembly
without -C: mangled names never contain the '>' that delimits a call's target.
"""
import re
import subprocess
import sys

FUNCTION = re.compile(r"^([0-9a-f]+) <(.+)>:$")
CALL = re.compile(r"\b(?:bl|b\.w|b)\s+[0-9a-f]+ <([^>]+)>")
REGISTER_LIST = re.compile(r"\{([^}]*)\}")


def count_registers(text):
    """Registers named in a {list}: r4, r5-r7, d8-d11, s16 ... -> (count, bytes per register)."""
    inner = REGISTER_LIST.search(text)
    if inner is None:
        return 0, 4
    count, size = 0, 4
    for item in inner.group(1).split(","):
        item = item.strip()
        if not item:
            continue
        size = 8 if item.startswith("d") else 4
        if "-" in item:
            lo, hi = item.split("-")
            count += int(re.sub(r"\D", "", hi)) - int(re.sub(r"\D", "", lo)) + 1
        else:
            count += 1
    return count, size


def frame_bytes(instruction):
    op = instruction.split(None, 1)
    if not op:
        return 0
    mnemonic, operands = op[0], op[1] if len(op) > 1 else ""
    if mnemonic in ("push", "push.w", "vpush") or (mnemonic.startswith("stmdb") and operands.startswith("sp!")):
        n, size = count_registers(operands)
        return n * size
    if mnemonic in ("sub", "sub.w", "subw") and re.match(r"sp,\s*(sp,\s*)?#", operands):
        return int(re.search(r"#(\d+)", operands).group(1))
    return 0


def parse(lines):
    functions = {}
    current = None
    for line in lines:
        line = line.rstrip("\n")
        m = FUNCTION.match(line)
        if m:
            current = m.group(2)
            functions[current] = {"frame": 0, "calls": set(), "indirect": False}
            continue
        if current is None or ":\t" not in line:
            continue
        instruction = line.split(":\t", 1)[1].split("@")[0].strip()
        functions[current]["frame"] += frame_bytes(instruction)
        if re.match(r"blx\s+r\d", instruction):
            functions[current]["indirect"] = True
        c = CALL.search(instruction)
        if c and "+0x" not in c.group(1) and c.group(1) != current:
            functions[current]["calls"].add(c.group(1))
    return functions


def deepest(functions, name, active):
    if name in active:
        sys.exit(f"stack_depth: recursion through {name}: no static bound")
    f = functions.get(name)
    if f is None:
        sys.exit(f"stack_depth: {name} is called but not in the image")
    if f["indirect"]:
        sys.exit(f"stack_depth: {name} makes an indirect call: no static bound")
    best, chain = 0, []
    for callee in sorted(f["calls"]):
        depth, sub = deepest(functions, callee, active | {name})
        if depth > best:
            best, chain = depth, sub
    return f["frame"] + best, [(name, f["frame"])] + chain


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: arm-none-eabi-objdump -d --no-show-raw-insn ELF | stack_depth.py NAME_PART")
    functions = parse(sys.stdin)
    roots = [n for n in functions if sys.argv[1] in n]
    if not roots:
        sys.exit(f"stack_depth: no function named like {sys.argv[1]!r}")
    total, chain = deepest(functions, roots[0], frozenset())
    names = subprocess.run(["arm-none-eabi-c++filt"], input="\n".join(n for n, _ in chain),
                           capture_output=True, text=True, check=True).stdout.split("\n")
    for (_, frame), name in zip(chain, names):
        print(f"  {frame:6d}  {name[:110]}")
    print(f"worst-case stack: {total} bytes")


if __name__ == "__main__":
    main()
