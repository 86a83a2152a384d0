#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Fails when README.md is longer than its limit (issue 21: read in ten minutes; the rest is docs/).

usage: readme_length.py README.md MAX_LINES
"""
import sys


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    path, limit = argv[1], int(argv[2])
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    print(f"{path}: {len(lines)} lines (limit {limit})")
    if len(lines) > limit:
        print(f"error: {path} has {len(lines)} lines, more than {limit}: move the detail into a docs/ page",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
