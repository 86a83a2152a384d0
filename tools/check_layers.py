#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Fails when an #include points up the layering (docs/architecture.md, "Layers and rooms").

Folders, lowest first; a file may include its own folder and any folder below it:
    msgs -> {plant, solvers, io} -> ecu -> hil -> targets
Inside hil/, the rooms, lowest first:
    config -> diag -> run -> kinds -> reference -> bus -> campaign
Every C++ source file carries an SPDX licence line (checked here too).

usage: tools/check_layers.py [ROOT]      (ROOT: the source tree, default: this script's ..)
       tools/check_layers.py --self-test (plants an upward include and a missing SPDX line
                                          in a temporary tree and checks both are caught)
"""
import os
import re
import sys
import tempfile

# what each top folder may include besides itself (the generated LCM types count as io)
TOP = {
    "msgs": set(),
    "plant": {"msgs"},
    "solvers": {"msgs"},
    "io": {"msgs", "ehpt_lcm"},
    "ecu": {"msgs", "plant"},
    "hil": {"msgs", "plant", "solvers", "io", "ecu", "ehpt_lcm"},
    "targets": {"msgs", "plant", "solvers", "io", "ecu", "hil", "ehpt_lcm"},
}
HIL_ROOMS = ["config", "diag", "run", "kinds", "reference", "bus", "campaign"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
SPDX = "SPDX-License-Identifier: BSD-3-Clause"


def check(root):
    problems = []
    for top in TOP:
        base = os.path.join(root, top)
        for dirpath, _, files in os.walk(base):
            for name in sorted(files):
                if not name.endswith((".hpp", ".cpp", ".cpp.in")):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                with open(path, encoding="utf-8") as f:
                    lines = f.read().split("\n")
                if not any(SPDX in line for line in lines[:3]):
                    problems.append(f"{rel}:1: no '{SPDX}' line in the first three lines")
                parts = rel.split(os.sep)
                room = parts[1] if top == "hil" and len(parts) > 2 else None
                if top == "hil" and room not in HIL_ROOMS:
                    problems.append(f"{rel}: hil/ holds rooms only ({', '.join(HIL_ROOMS)}); "
                                    "a file directly in hil/ or in another folder has no rank")
                    continue
                for no, line in enumerate(lines, 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    target = m.group(1).split("/")
                    if len(target) < 2:
                        continue  # a sibling include without a folder: not ehpt's style, not a layer
                    dest = target[0]
                    if dest != top and (dest in TOP or dest == "ehpt_lcm") and dest not in TOP[top]:
                        problems.append(f"{rel}:{no}: {top}/ includes {m.group(1)}: {top}/ may include "
                                        f"only {', '.join(sorted(TOP[top])) or 'itself'}")
                    if top == "hil" and dest == "hil" and len(target) > 2:
                        to_room = target[1]
                        if to_room not in HIL_ROOMS:
                            problems.append(f"{rel}:{no}: includes {m.group(1)}, which is in no room")
                        elif HIL_ROOMS.index(to_room) > HIL_ROOMS.index(room):
                            problems.append(f"{rel}:{no}: hil/{room}/ includes {m.group(1)}, a higher room "
                                            f"(order: {' -> '.join(HIL_ROOMS)})")
    return problems


def self_test():
    with tempfile.TemporaryDirectory() as root:
        def write(rel, text):
            os.makedirs(os.path.dirname(os.path.join(root, rel)), exist_ok=True)
            with open(os.path.join(root, rel), "w", encoding="utf-8") as f:
                f.write(text)
        ok = f"// {SPDX}\n"
        write("hil/run/a.hpp", ok + '#include "hil/config/b.hpp"\n')
        write("hil/config/b.hpp", ok)
        write("plant/c.hpp", ok + '#include "msgs/d.hpp"\n')
        write("msgs/d.hpp", ok)
        if check(root):
            print("self-test: a clean tree was refused:", check(root))
            return 1
        write("hil/config/b.hpp", ok + '#include "hil/run/a.hpp"\n')
        write("plant/c.hpp", ok + '#include "hil/run/a.hpp"\n')
        write("msgs/d.hpp", "// no licence line\n")
        found = check(root)
        want = ["hil/config/b.hpp:2", "plant/c.hpp:2", "msgs/d.hpp:1"]
        missing = [w for w in want if not any(p.startswith(w) for p in found)]
        if missing or len(found) != len(want):
            print("self-test: expected exactly", want, "got", found)
            return 1
    print("self-test: an upward room include, an upward folder include and a missing SPDX line are caught")
    return 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    problems = check(root)
    for p in problems:
        print(p)
    if problems:
        print(f"check_layers: {len(problems)} problem(s); the rule is in docs/architecture.md")
        return 1
    print("check_layers: every include points down the layers, every source file has its SPDX line")
    return 0


if __name__ == "__main__":
    sys.exit(main())
