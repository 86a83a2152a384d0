#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Fails when the README or a docs/ page other than docs/speed.md quotes a speed figure.

usage: no_speed_figures.py SOURCE_DIR

The one speed table (docs/speed.md, generated from `ehpt bench` by tools/speed_table.py) holds
every speed figure of the documentation; other pages say "see speed.md". A speed figure here
is a number followed by a per-step time, a real-time factor, a rate of ECU periods, runs or
samples, or a time per step or sample. Release history (CHANGELOG.md) is not documentation
of today's speed and is not checked.
"""
import glob
import os
import re
import sys

FIGURE = re.compile(
    r"\d[\d.,\u2009 ]*\s*(?:"
    r"ns(?:\s+per\s+step|/step)|"
    r"µs\s+per\s+(?:step|sample|message|period)|"
    r"(?:×|x)\s+real[ -]time|"
    r"(?:ECU\s+)?periods\s+per\s+second|"
    r"runs\s+per\s+minute|"
    r"messages\s+per\s+second|"
    r"s\s+of\s+CPU\s+per\s+simulated\s+second)",
    re.IGNORECASE)


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    root = argv[1]
    pages = [os.path.join(root, "README.md")] + sorted(glob.glob(os.path.join(root, "docs", "*.md")))
    problems = []
    for page in pages:
        if os.path.basename(page) == "speed.md":
            continue
        try:
            with open(page, encoding="utf-8") as f:
                lines = f.read().split("\n")
        except OSError as e:
            print(f"error: {page}: {e.strerror}", file=sys.stderr)
            return 2
        for number, line in enumerate(lines, 1):
            for m in FIGURE.finditer(line):
                problems.append(f"{os.path.relpath(page, root)}:{number}: '{m.group(0).strip()}': a speed "
                                "figure outside docs/speed.md (say 'see speed.md')")
    for p in problems:
        print(p, file=sys.stderr)
    print(f"{len(pages)} pages checked, {len(problems)} speed figures outside docs/speed.md")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
