#!/usr/bin/env python3
"""Code lines of rnd-core's render code (#17's line budget).

Usage: bench/code_lines.py [FILE[:FIRST-LAST] ...]

Counts the lines of each file that are code: not blank, not a comment (`//`, `///`,
`//!` or inside `/* */`), and not inside an item marked `#[cfg(test)]` (a test module,
or a method kept for the unit tests). With no arguments, the render code: render.rs,
march.rs, arith.rs, refarith.rs and skip.rs of rnd-core/src. FILE:FIRST-LAST counts
only lines FIRST to LAST of FILE (1-based, inclusive).
"""

import os
import sys

RENDER = ["render.rs", "march.rs", "arith.rs", "refarith.rs", "skip.rs"]


def code_lines(text):
    """The 1-based numbers of the code lines of Rust source `text`."""
    lines = text.split("\n")
    code = set()
    i, in_block = 0, False
    while i < len(lines):
        s = lines[i].strip()
        if in_block:
            in_block = "*/" not in s
            i += 1
            continue
        if s.startswith("#[cfg(test)]"):
            # Skip the item it marks: up to the brace that closes its first block
            # (or its first line ending in `;`, for an item without a body).
            depth, opened, j = 0, False, i + 1
            while j < len(lines):
                t = lines[j]
                depth += t.count("{") - t.count("}")
                opened |= "{" in t
                j += 1
                if (opened and depth <= 0) or (not opened and t.rstrip().endswith(";")):
                    break
            i = j
            continue
        if s.startswith("/*"):
            in_block = "*/" not in s
        elif s and not s.startswith("//"):
            code.add(i + 1)
        i += 1
    return code


def main(args):
    src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "rnd-core", "src")
    specs = args or [os.path.join(src, f) for f in RENDER]
    total = 0
    for spec in specs:
        path, _, span = spec.partition(":")
        if not os.path.exists(path) and os.path.exists(os.path.join(src, path)):
            path = os.path.join(src, path)
        with open(path, encoding="utf-8") as f:
            code = code_lines(f.read())
        if span:
            first, last = (int(x) for x in span.split("-"))
            code = {n for n in code if first <= n <= last}
        total += len(code)
        print(f"{len(code):6d}  {os.path.relpath(path)}{':' + span if span else ''}")
    print(f"{total:6d}  total")


if __name__ == "__main__":
    main(sys.argv[1:])
