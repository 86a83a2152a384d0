#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""docs/fmu-variables.md, made by `ehpt fmu --variables`: the variables of an FMU of each shipped
vehicle (one scenario per vehicle file), and what --ecu none adds for the two vehicles with
ECU messages.

    tools/fmu_variables.py EHPT > docs/fmu-variables.md     write it
    tools/fmu_variables.py EHPT --check docs/fmu-variables.md  exit 1 if it differs (ctest)
"""
import subprocess
import sys

SCENARIOS = ["psecu2_nedc", "psecu1_nedc", "psecu1soc_nedc", "ev_nedc", "evpm_nedc", "evam_nedc", "evam_pu_sort1",
             "battery_cc_discharge", "one_flange_test", "two_flange_test", "test_pm_drive", "test_am_drive",
             "genset_test2", "genset_test_oo", "shev_power_filt_sort1", "shev_power_filt_soc_sort1", "shev_oo_sort1",
             "shev_oo_nomaps_sort1"]
WITHOUT_ECU = ["psecu2_nedc", "ev_nedc"]


def ehpt(*args):
    r = subprocess.run([sys.argv[1]] + list(args), capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        sys.exit("ehpt %s: %s" % (" ".join(args), r.stderr))
    return r.stdout


def document():
    out = ["# FMU variables\n",
           "Made by `tools/fmu_variables.py` from `ehpt fmu SCENARIO --variables` (ctest",
           "`fmu_variables_doc` fails when this page and the tool differ). One shipped scenario per",
           "vehicle file; [fmu.md](fmu.md) says what each kind of variable does. The value references",
           "are the FMI 3.0 FMU's; FMI 2.0 has the same ones, without `time`. The parameters' start",
           "values are the vehicle file's, or the default where the file leaves a number out.\n"]
    for name in SCENARIOS:
        description = [l for l in ehpt("list").splitlines() if l.split()[:1] == [name]]
        out.append("## %s\n" % name)
        if description:
            out.append(description[0][len(name):].strip() + ". `ehpt fmu %s`:\n" % name)
        out.append(ehpt("fmu", name, "--variables"))
        if name in WITHOUT_ECU:
            rows = [l for l in ehpt("fmu", name, "--ecu", "none", "--variables").splitlines()
                    if "`sensors." in l or "`command." in l]
            out.append("With `--ecu none` (model identifier `ehpt_%s_plant`), these come after the signals, and "
                       "the parameters' value references move up by as many:\n" % name)
            out.append("| vr | name | causality | unit | start | description |\n|---|---|---|---|---|---|\n" +
                       "\n".join(rows) + "\n")
    return "\n".join(out)


text = document()
if len(sys.argv) > 3 and sys.argv[2] == "--check":
    with open(sys.argv[3]) as f:
        same = f.read() == text
    if not same:
        print("%s differs from `tools/fmu_variables.py EHPT`: run it and commit the page" % sys.argv[3])
    sys.exit(0 if same else 1)
sys.stdout.write(text)
