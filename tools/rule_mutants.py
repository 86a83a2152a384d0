#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""The validation rules of ehpt's inputs, found in the sources, as planted defects.

Two groups:
  plant   every statement of a `validate*` or `check_*` function of plant/ and ecu/ (and of
          the small helpers they call) that reports a problem or calls a function that does;
  config  every statement of hil/config/ and hil/kinds/ that reports an error or a warning
          while a scenario, a vehicle file or a table is read (ctx.error, ctx.warn, ...);
  dbc     every statement of the DBC reader (io/can/dbc.cpp) that refuses a DBC or warns
          (throw ParseError, error, warning).
For each rule this prints a tools/mutate.sh line that disables it (`if (false) ` in front of
the statement), so that a mutate run shows which rules a test catches:

  tools/mutate.sh --list <(tools/rule_mutants.py list plant) --target validation_rules_tests \
      --tests ValidationRules
  tools/mutate.sh --list <(tools/rule_mutants.py list config) --target hil_tests --target cli_tests \
      --tests 'REGEX'    (docs/validation-rules.md gives the one used)

  rule_mutants.py list [GROUP]    the mutants (FILE:LINE | TEXT | REPLACEMENT | WHAT)
  rule_mutants.py table LOG       the rows of docs/validation-rules.md's table from the output
                                  of that tools/mutate.sh run
  rule_mutants.py check DOC       fails if a rule found here is missing from DOC's table
                                  (docs/validation-rules.md): a new rule needs a row, a test
                                  and a planted run
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCES = ["plant", "ecu"]
CONFIG_SOURCES = ["hil/config", "hil/kinds"]
DBC_SOURCES = ["io/can/dbc.cpp"]
DBC_CALL = re.compile(r"^(?:\} else )?(?:if \(.*\) )?(throw ParseError|error|warning)[{(]")
# a statement of the readers that reports an error or a warning
CONFIG_CALL = re.compile(
    r"^(?:\} else )?(?:if \(.*\) )?(ctx_?\.error|ctx_?\.warn|ctx_?\.errors\.push_back|errors\.push_back|problems\.add|warnings\.add)\(")
# the functions whose statements are rules
FUNCTION = re.compile(r"^(?:static\s+)?void\s+(?:\w+::)?(validate\w*|check_\w+|positive|pole_pairs)\s*\(")
# a statement that reports a problem or delegates to a function that does
CALL = re.compile(
    r"^(?:if \(.*\) )?(problems\.(?:require_\w+|add_cell|add)|(?:\w+::)?(?:validate\w*|check_\w+)|positive|pole_pairs|opt_positive)\(")


def functions(text):
    """(name, first line index, last line index) of each top-level rule function."""
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        m = FUNCTION.match(lines[i])
        if m and lines[i].rstrip().endswith("{"):
            j = i + 1
            while j < len(lines) and lines[j] != "}":
                j += 1
            yield m.group(1), i, j
            i = j
        i += 1


def rules():
    """(file, line number, statement text, the field it names) for every rule statement."""
    out = []
    for folder in SOURCES:
        for name in sorted(os.listdir(os.path.join(HERE, folder))):
            if not name.endswith((".cpp", ".hpp")):
                continue
            rel = f"{folder}/{name}"
            text = open(os.path.join(HERE, rel), encoding="utf-8").read()
            lines = text.split("\n")
            for _, first, last in functions(text):
                for k in range(first + 1, last):
                    stmt = lines[k].strip()
                    if stmt.startswith("//") or not CALL.match(stmt):
                        continue
                    out.append((rel, k + 1, stmt, field_of(lines, k)))
    return out


def field_of(lines, k):
    """The field a rule names (its first ".name" or "name" literal), else its message."""
    stmt = lines[k].strip()
    field = re.search(r'"\.?([A-Za-z_][\w.\[\]]*)"', stmt)
    if field:
        return field.group(1)
    # a helper's rule (the caller names the field): the message, up to the statement's end
    text = stmt
    while not text.rstrip().endswith(";") and k + 1 < len(lines):
        k += 1
        text += " " + lines[k].strip()
    literals = [t for t in re.findall(r'"([^"]*)"', text) if t.strip(" .")]
    if literals:
        return max(literals, key=len).strip(" (")
    return CALL.match(stmt).group(1) + "(...)"  # a call that checks fields its caller names


def config_rules():
    """(file, line number, statement text, what it reports) for every reader's rule statement."""
    out = []
    for folder in CONFIG_SOURCES:
        for name in sorted(os.listdir(os.path.join(HERE, folder))):
            if not name.endswith((".cpp", ".hpp")):
                continue
            rel = f"{folder}/{name}"
            lines = open(os.path.join(HERE, rel), encoding="utf-8").read().split("\n")
            for k, line in enumerate(lines):
                stmt = line.strip()
                if CONFIG_CALL.match(stmt):
                    out.append((rel, k + 1, stmt, config_field_of(lines, k)))
    return out


def dbc_rules():
    """(file, line number, statement text, its message) for every refusal or warning of the DBC reader."""
    out = []
    for rel in DBC_SOURCES:
        lines = open(os.path.join(HERE, rel), encoding="utf-8").read().split("\n")
        for k, line in enumerate(lines):
            stmt = line.strip()
            if DBC_CALL.match(stmt) and not stmt.startswith(("error(line, e.problem)", "error(lex_.line(), problem)")):
                out.append((rel, k + 1, stmt, config_field_of(lines, k)))
    return out


def config_field_of(lines, k):
    """A reader's rule by its message: the longest literal of the statement."""
    text = lines[k].strip()
    while not text.rstrip().endswith(";") and k + 1 < len(lines):
        k += 1
        text += " " + lines[k].strip()
    literals = [t for t in re.findall(r'"((?:[^"\\]|\\.)*)"', text) if len(t.strip(" .:")) > 2]
    return max(literals, key=len).strip(" (:").replace("\\\"", "'") if literals else text.split("(")[0]


def mutant(stmt, pattern=None):
    """The statement disabled: `if (false) ` before the call (after an `if (...)` it guards)."""
    m = (pattern or CALL).match(stmt)
    at = m.start(1)
    return stmt[:at] + "if (false) " + stmt[at:]


def main():
    if len(sys.argv) < 2 or sys.argv[1] not in ("list", "table", "check"):
        sys.exit(__doc__)
    found = rules() + config_rules() + dbc_rules()
    if sys.argv[1] == "list":
        group = sys.argv[2] if len(sys.argv) > 2 else "plant"
        groups = {"plant": (rules, CALL), "config": (config_rules, CONFIG_CALL), "dbc": (dbc_rules, DBC_CALL)}
        if group not in groups:
            sys.exit("rule_mutants: the group is plant, config or dbc")
        print(f"# generated by tools/rule_mutants.py: one per validation rule ({group})")
        finder, pattern = groups[group]
        for rel, line, stmt, field in finder():
            print(f"{rel}:{line} | {stmt} | {mutant(stmt, pattern)} | rule {field}")
        return
    if sys.argv[1] == "table":
        # mutate.sh prints "RESULT     FILE: rule FIELD", one line per mutant, in list order
        result = re.compile(r"^(killed|SURVIVED|NOT VIABLE|STALE)\s+(\S+): rule (.*?)(?: \(text not found.*)?$")
        print("| source | rule: the field, or a helper's message | disabled, the test |")
        print("|---|---|---|")
        for line in open(sys.argv[2], encoding="utf-8"):
            m = result.match(line.rstrip("\n"))
            if m:
                verdict = {"killed": "fails", "SURVIVED": "**passes: untested**"}.get(m.group(1), m.group(1).lower())
                print(f"| {m.group(2)} | `{m.group(3)}` | {verdict} |")
        return
    doc = open(sys.argv[2], encoding="utf-8").read()
    missing = [(rel, line, field) for rel, line, _, field in found if f"| {rel} | `{field}` |" not in doc]
    for rel, line, field in missing:
        print(f"{sys.argv[2]}: no row for the rule of {rel}:{line} ({field}): add it with its test "
              f"and plant it (tools/mutate.sh)", file=sys.stderr)
    print(f"rule_mutants: {len(found)} rules, {len(found) - len(missing)} in {sys.argv[2]}")
    sys.exit(1 if missing else 0)


if __name__ == "__main__":
    main()
