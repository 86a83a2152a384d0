#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Mutation test: plants each defect of tools/mutants.txt, one at a time, into a private copy of
# the tree (build-mutate/src; the working tree is never touched), rebuilds, runs the whole
# test suite, and counts the defects the suite catches ("killed").
# usage: tools/mutate.sh [PATTERN]      (only the mutants whose line contains PATTERN)
# A mutant that does not compile is "not viable" and does not count. Prints the kill ratio.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
exec /usr/bin/python3 - "$here" "${1:-}" <<'PY'
import os, shutil, subprocess, sys

here, pattern = sys.argv[1], sys.argv[2]
work = os.path.join(here, "build-mutate")
src, build = os.path.join(work, "src"), os.path.join(work, "build")
jobs = str(os.cpu_count() or 2)
os.makedirs(work, exist_ok=True)
open(os.path.join(work, ".gitignore"), "w").write("*\n")

def run(args, **kw):
    return subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, **kw).returncode

# the mutants: FILE | TEXT | REPLACEMENT | WHAT (fields split on " | ")
mutants = []
for line in open(os.path.join(here, "tools", "mutants.txt"), encoding="utf-8"):
    line = line.rstrip("\n")
    if not line.strip() or line.startswith("#") or (pattern and pattern not in line):
        continue
    fields = line.split(" | ")
    if len(fields) != 4:
        sys.exit(f"mutate: tools/mutants.txt: expected 4 fields split by ' | ': {line[:80]}")
    mutants.append([f.strip() if i in (0, 3) else f for i, f in enumerate(fields)])

# a copy of the working tree as it is (tracked files, uncommitted edits included)
shutil.rmtree(src, ignore_errors=True)
os.makedirs(src)
files = subprocess.run(["git", "ls-files", "-z"], cwd=here, capture_output=True, check=True).stdout.split(b"\0")
for f in files:
    if not f:
        continue
    rel = f.decode()
    if os.path.isfile(os.path.join(here, rel)):
        os.makedirs(os.path.dirname(os.path.join(src, rel)) or src, exist_ok=True)
        # a fresh modification time: the build must not take the copy for older than its objects
        shutil.copy(os.path.join(here, rel), os.path.join(src, rel))
run(["cmake", "-S", src, "-B", build, "-DCMAKE_BUILD_TYPE=Release", "-DEHPT_BUILD_BENCH=OFF"])
print("mutate: building and testing the unmutated copy", file=sys.stderr, flush=True)
if run(["cmake", "--build", build, "-j", jobs]) != 0 or run(["ctest", "-j", jobs], cwd=build) != 0:
    sys.exit("mutate: the unmutated suite fails; fix it first")

killed = survived = not_viable = stale = 0
survivors = []
for file, old, new, what in mutants:
    path = os.path.join(src, file)
    text = open(path, encoding="utf-8").read()
    if text.count(old) != 1:
        print(f"STALE      {file}: {what} (text not found exactly once)", flush=True)
        stale += 1
        continue
    open(path, "w", encoding="utf-8").write(text.replace(old, new))
    try:
        if run(["cmake", "--build", build, "-j", jobs]) != 0:
            result = "NOT VIABLE"
            not_viable += 1
        elif run(["ctest", "-j", jobs, "--stop-on-failure", "--timeout", "300"], cwd=build) == 0:
            result = "SURVIVED"
            survived += 1
            survivors.append(f"{file}: {what}")
        else:
            result = "killed"
            killed += 1
    finally:
        open(path, "w", encoding="utf-8").write(text)
    print(f"{result:<10} {file}: {what}", flush=True)
run(["cmake", "--build", build, "-j", jobs])  # leave the copy built as it is

viable = killed + survived
ratio = 100 * killed // viable if viable else 0
print(f"\nmutants: {killed} killed, {survived} survived, {not_viable} not viable, {stale} stale; "
      f"kill ratio {killed}/{viable} = {ratio} %")
for s in survivors:
    print(f"  survived: {s}")
PY
