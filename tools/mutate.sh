#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Mutation test: plants each defect of tools/mutants.txt, one at a time, into a private copy of
# the tree (build-mutate/src; the working tree is never touched), rebuilds, runs the whole
# test suite, and counts the defects the suite catches ("killed").
# usage: tools/mutate.sh [--list FILE] [--target TARGET] [--tests REGEX] [PATTERN]
#   --list FILE      the mutants (default tools/mutants.txt; FILE may be a pipe, e.g.
#                    <(tools/rule_mutants.py list), the validation rules of plant/ and ecu/)
#   --target TARGET  build only this target after each mutation (default: everything; may be
#                    given more than once)
#   --tests REGEX    run only the tests ctest -R REGEX selects (default: the whole suite)
#   PATTERN          only the mutants whose line contains PATTERN
# FILE:LINE in a mutant's first field replaces TEXT on that line only (for a statement that
# occurs more than once in its file). A mutant that does not compile is "not viable" and does
# not count. Prints the kill ratio. EHPT_MUTATE_DIR=DIR works in DIR instead of build-mutate/
# (two runs at once).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
list="$here/tools/mutants.txt" target="" tests="" pattern=""
while [ $# -gt 0 ]; do
  case "$1" in
    --list) list="$2"; shift 2 ;;
    --target) target="$target $2"; shift 2 ;;
    --tests) tests="$2"; shift 2 ;;
    -h|--help) sed -n '3,16p' "$0"; exit 0 ;;
    -*) echo "mutate: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) pattern="$1"; shift ;;
  esac
done
# the list is read here: a pipe given as --list does not survive the exec below
mutants_text="$(cat "$list")" || { echo "mutate: cannot read $list" >&2; exit 2; }
exec /usr/bin/python3 - "$here" "$pattern" "$target" "$tests" "$mutants_text" <<'PY'
import os, shutil, subprocess, sys

here, pattern, target, tests, mutants_text = sys.argv[1:6]
build_cmd = lambda: ["cmake", "--build", build, "-j", jobs] + (["--target"] + target.split() if target.strip() else [])
# --no-tests=error: a --tests REGEX that selects nothing would let every mutant "survive" unseen
test_cmd = lambda: ["ctest", "-j", jobs, "--no-tests=error"] + (["-R", tests] if tests else [])
work = os.environ.get("EHPT_MUTATE_DIR") or os.path.join(here, "build-mutate")  # EHPT_MUTATE_DIR: a second run beside the first
src, build = os.path.join(work, "src"), os.path.join(work, "build")
jobs = str(os.cpu_count() or 2)
os.makedirs(work, exist_ok=True)
open(os.path.join(work, ".gitignore"), "w").write("*\n")

def run(args, **kw):
    return subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, **kw).returncode

# the mutants: FILE | TEXT | REPLACEMENT | WHAT (fields split on " | ")
mutants = []
for line in mutants_text.split("\n"):
    if not line.strip() or line.startswith("#") or (pattern and pattern not in line):
        continue
    fields = line.split(" | ")
    if len(fields) != 4:
        sys.exit(f"mutate: expected 4 fields split by ' | ': {line[:80]}")
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
launcher = ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"] if shutil.which("ccache") else []
run(["cmake", "-S", src, "-B", build, "-DCMAKE_BUILD_TYPE=Release", "-DEHPT_BUILD_BENCH=OFF"] + launcher)
print("mutate: building and testing the unmutated copy", file=sys.stderr, flush=True)
if run(build_cmd()) != 0 or run(test_cmd(), cwd=build) != 0:
    sys.exit("mutate: the unmutated suite fails; fix it first")

killed = survived = not_viable = stale = 0
survivors = []
def mutated(text, old, new, line_no):
    """text with old replaced by new (on line line_no only, if given); None if not exactly once."""
    if line_no is None:
        return text.replace(old, new) if text.count(old) == 1 else None
    lines = text.split("\n")
    if not (1 <= line_no <= len(lines)) or lines[line_no - 1].count(old) != 1:
        return None
    lines[line_no - 1] = lines[line_no - 1].replace(old, new)
    return "\n".join(lines)

for file, old, new, what in mutants:
    file, _, line_no = file.partition(":")
    path = os.path.join(src, file)
    text = open(path, encoding="utf-8").read()
    changed = mutated(text, old, new, int(line_no) if line_no else None)
    if changed is None:
        print(f"STALE      {file}: {what} (text not found exactly once{' on line ' + line_no if line_no else ''})",
              flush=True)
        stale += 1
        continue
    open(path, "w", encoding="utf-8").write(changed)
    try:
        if run(build_cmd()) != 0:
            result = "NOT VIABLE"
            not_viable += 1
        elif run(test_cmd() + ["--stop-on-failure", "--timeout", "300"], cwd=build) == 0:
            result = "SURVIVED"
            survived += 1
            survivors.append(f"{file}: {what}")
        else:
            result = "killed"
            killed += 1
    finally:
        open(path, "w", encoding="utf-8").write(text)
    print(f"{result:<10} {file}: {what}", flush=True)
run(build_cmd())  # leave the copy built as it is

viable = killed + survived
ratio = 100 * killed // viable if viable else 0
print(f"\nmutants: {killed} killed, {survived} survived, {not_viable} not viable, {stale} stale; "
      f"kill ratio {killed}/{viable} = {ratio} %")
for s in survivors:
    print(f"  survived: {s}")
PY
