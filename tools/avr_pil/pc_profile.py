#!/usr/bin/python3
"""Sums avr_pil --pc-profile output by function.

    pc_profile.py ELF PROFILE [--per N] [--top K]
    pc_profile.py --diff ELF_A PROFILE_A ELF_B PROFILE_B [--per-a N] [--per-b N] [--top K]
    pc_profile.py --calls ELF PROFILE [--per N] [--to NAMES] [--top K]

The functions come from the image's symbol table (avr-nm), the cycles from PROFILE ("address cycles" in
hex and decimal per line). --per divides by a count (the flown iterations) to give cycles per iteration;
--diff lists the functions whose cycles per iteration differ most between two images. --calls counts the
calls to the functions NAMES (comma-separated; default avr-libc's float comparisons) by caller: a call
site's cycles divided by the cycles of its CALL instruction (5 on the ATmega2560, RCALL 4) are the times
it ran.
"""
import bisect
import re
import subprocess
import sys


def symbols(elf):
    out = subprocess.run(["avr-nm", "-nC", "--defined-only", elf], capture_output=True, text=True, check=True).stdout
    table = []
    for line in out.splitlines():
        parts = line.split(None, 2)
        # (__stack is the top of RAM, not code, whatever its address reads as in program space.)
        if len(parts) == 3 and parts[1] in "tTwW" and parts[2] != "__stack":
            table.append((int(parts[0], 16), parts[2]))
    table.sort()
    return table


def by_function(elf, profile):
    table = symbols(elf)
    starts = [a for a, _ in table]
    sums = {}
    with open(profile) as f:
        for line in f:
            address, cycles = line.split()
            i = bisect.bisect_right(starts, int(address, 16)) - 1
            name = table[i][1] if i >= 0 else "?"
            sums[name] = sums.get(name, 0) + int(cycles)
    return sums


FLOAT_COMPARISONS = "__cmpsf2,__eqsf2,__nesf2,__ltsf2,__lesf2,__gtsf2,__gesf2,__unordsf2"


def calls_by_caller(elf, profile, targets):
    """{(caller, callee): times run} for the CALL/RCALL sites of the image whose target is in targets."""
    cycles = {}
    with open(profile) as f:
        for line in f:
            address, c = line.split()
            cycles[int(address, 16)] = int(c)
    out = subprocess.run(["avr-objdump", "-d", "-C", elf], capture_output=True, text=True, check=True).stdout
    site = re.compile(r"^\s+([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(r?call)\s+.*<([^>+]+)>")
    counts = {}
    caller = "?"
    for line in out.splitlines():
        m = re.match(r"^[0-9a-f]+ <(.*)>:", line)
        if m:
            caller = m.group(1)
            continue
        m = site.match(line)
        if m and m.group(3) in targets:
            ran = cycles.get(int(m.group(1), 16), 0) / (5 if m.group(2) == "call" else 4)
            key = (caller, m.group(3))
            counts[key] = counts.get(key, 0) + ran
    return counts


def option(args, name, default):
    if name in args:
        i = args.index(name)
        value = args[i + 1]
        del args[i:i + 2]
        return value
    return default


def main(args):
    top = int(option(args, "--top", "40"))
    if args and args[0] == "--calls":
        per = float(option(args, "--per", "1"))
        targets = set(option(args, "--to", FLOAT_COMPARISONS).split(","))
        counts = calls_by_caller(args[1], args[2], targets)
        print(f"calls per iteration: {sum(counts.values()) / per:.2f}")
        for (caller, callee), n in sorted(counts.items(), key=lambda r: -r[1])[:top]:
            if n > 0:
                print(f"{n / per:8.2f}  {callee:10s} {caller}")
        return 0
    if args and args[0] == "--diff":
        per_a = float(option(args, "--per-a", "1"))
        per_b = float(option(args, "--per-b", "1"))
        a = by_function(args[1], args[2])
        b = by_function(args[3], args[4])
        names = set(a) | set(b)
        rows = [(b.get(n, 0) / per_b - a.get(n, 0) / per_a, n) for n in names]
        rows.sort(key=lambda r: -abs(r[0]))
        print(f"total per iteration: A {sum(a.values()) / per_a:.0f}, B {sum(b.values()) / per_b:.0f}")
        for d, n in rows[:top]:
            print(f"{d:+10.1f}  A {a.get(n, 0) / per_a:9.1f}  B {b.get(n, 0) / per_b:9.1f}  {n}")
        return 0
    per = float(option(args, "--per", "1"))
    sums = by_function(args[0], args[1])
    print(f"total {sum(sums.values()) / per:.0f}")
    for n, c in sorted(sums.items(), key=lambda r: -r[1])[:top]:
        print(f"{c / per:10.1f}  {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
