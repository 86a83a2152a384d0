#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Runs the README's quick start as written.

usage: readme_quickstart.py README.md EHPT_BINARY [--print]

Takes every fenced ```sh block between the lines `<!-- quickstart:begin -->` and
`<!-- quickstart:end -->` of README.md, in order, and runs them as one script with
`bash -e -o pipefail` in a fresh temporary folder (the newcomer's own folder), with the
folder of EHPT_BINARY first on PATH and EHPT_SCENARIOS unset; inside a private network
namespace where one can be made (its loopback only: the quick start's bus port cannot
collide with another test's). Exit 0 when every command
succeeded; otherwise the failing command's status, with its output. --print only lists the
commands. The whole quick start must finish within the limit below (ctest adds its own).
"""
import os
import subprocess
import sys
import tempfile

BEGIN = "<!-- quickstart:begin -->"
END = "<!-- quickstart:end -->"
LIMIT_S = 100


def private_network():
    try:
        return subprocess.run(["unshare", "-n", "true"], stderr=subprocess.DEVNULL, timeout=10).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def blocks(readme_text):
    lines = readme_text.split("\n")
    begins = [i for i, line in enumerate(lines) if line.strip() == BEGIN]
    ends = [i for i, line in enumerate(lines) if line.strip() == END]
    if len(begins) != 1 or len(ends) != 1 or ends[0] < begins[0]:
        raise ValueError(f"needs exactly one '{BEGIN}' line and, after it, one '{END}' line")
    out, current = [], None
    for line in lines[begins[0] + 1:ends[0]]:
        if current is None:
            if line.strip() == "```sh":
                current = []
            elif line.strip().startswith("```"):
                continue
        elif line.strip() == "```":
            out.append("\n".join(current))
            current = None
        else:
            current.append(line)
    if current is not None:
        raise ValueError("a ```sh block is not closed before the end marker")
    if not out:
        raise ValueError("no ```sh block between the markers")
    return out


def main(argv):
    if len(argv) not in (3, 4) or (len(argv) == 4 and argv[3] != "--print"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    readme, binary = argv[1], os.path.abspath(argv[2])
    with open(readme, encoding="utf-8") as f:
        try:
            script_blocks = blocks(f.read())
        except ValueError as e:
            print(f"error: {readme}: {e}", file=sys.stderr)
            return 2
    script = "\n\n".join(script_blocks) + "\n"
    if len(argv) == 4:
        print(script, end="")
        return 0
    if not os.access(binary, os.X_OK):
        print(f"error: {binary}: not an executable", file=sys.stderr)
        return 2
    env = dict(os.environ)
    env.pop("EHPT_SCENARIOS", None)
    env["PATH"] = os.path.dirname(binary) + os.pathsep + env.get("PATH", "")
    with tempfile.TemporaryDirectory(prefix="ehpt-quickstart-") as work:
        with open(os.path.join(work, ".quickstart.sh"), "w", encoding="utf-8") as f:
            f.write(script)
        print(f"running {len(script_blocks)} blocks of {readme} in {work}:\n{script}", flush=True)
        try:
            # -x: each command is echoed before it runs, so a failure names its command
            command = ["bash", "-e", "-o", "pipefail", "-x", ".quickstart.sh"]
            if private_network():
                # a private loopback: the quick start's TCP port cannot meet another test's
                command = ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "quickstart"] + command
            else:
                print("note: no private network namespace here; the quick start uses the host's loopback")
            done = subprocess.run(command, cwd=work, env=env, timeout=LIMIT_S, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            print(f"error: the quick start did not finish within {LIMIT_S} s", file=sys.stderr)
            return 1
        if done.returncode != 0:
            print(f"error: the quick start failed (exit {done.returncode}) at the last command echoed above",
                  file=sys.stderr)
            return 1
        leftover = [p for p in os.listdir(work) if p != ".quickstart.sh"]
        print(f"quick start ok; it made {sorted(leftover)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
