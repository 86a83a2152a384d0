#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""ehpt fmu end to end, with the project's importer (tests/fmu/fmu_run.cpp):

    /usr/bin/python3 tests/fmu/fmu_e2e_test.py EHPT FMU_RUN SOURCE_DIR [clean]

For every shipped scenario (every vehicle kind): `ehpt fmu` (2 s, FMI 3.0 and FMI 2.0), then
- modelDescription.xml is well formed (xmllint) and has what FMI 3.0 requires of it: fmiVersion,
  a non-empty instantiationToken, CoSimulation with modelIdentifier whose library is in
  binaries/x86_64-linux/, exactly one independent variable, valueReferences unique, causality
  and variability from the standard's sets, every unit declared in UnitDefinitions, the
  ModelStructure's Outputs exactly the output variables in order, a DefaultExperiment;
- the FMU run by fmu_run in communication steps of 10 plant steps prints the rows of `ehpt run`'s
  timeseries.csv (output.interval_s = 10 steps), character for character;
- FMI 2.0: what it requires (one type element per ScalarVariable, value references unique per
  type, Outputs and InitialUnknowns by 1-based index, inputs with start), and the same rows.
--bus ls-bus: the plant FMU and the ECU FMU (FMI-LS-BUS CAN terminals) are complete FMI 3.0
(Binary inputs with a Start, each clocked variable's clock a Clock, the MIME type, Event Mode,
terminalsAndIcons.xml naming the four members, the layered standard's manifest, the DBC), and
fmu_run connecting them Tx_Data to Rx_Data prints the rows of a real lockstep session over
socketcand (`ehpt plant --lockstep` + `ehpt ecu`), character for character.
With `clean`: one FMU run where nothing of ehpt is reachable: a mount namespace with an empty
tmpfs over the source (and build) tree and over an installed /usr/share/ehpt, and the system's
libtomlplusplus.so.3 hidden (the FMU's library has toml++ compiled in); the rows are again
ehpt run's.
77 (skipped) if this user cannot make a mount namespace.
"""
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
import zipfile

EHPT, FMU_RUN, SRC = (os.path.abspath(a) for a in sys.argv[1:4])
CLEAN = len(sys.argv) > 4 and sys.argv[4] == "clean"
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def ehpt(*args):
    return subprocess.run([EHPT] + list(args), capture_output=True, text=True, timeout=300)


def model_description_problems_2(root, names):
    """What FMI 2.0 requires of a co-simulation modelDescription.xml."""
    problems = []
    if root.get("fmiVersion") != "2.0" or not root.get("guid") or not root.get("modelName"):
        problems.append("fmiVersion 2.0, guid, modelName")
    cs = root.find("CoSimulation")
    if cs is None or "binaries/x86_64-linux/%s.so" % cs.get("modelIdentifier") not in names:
        problems.append("CoSimulation modelIdentifier and its library")
    units = {u.get("name") for u in root.iter("Unit")}
    variables = list(root.find("ModelVariables"))
    seen = set()
    for v in variables:
        typed = [c for c in v if c.tag in ("Real", "Integer", "Boolean", "String", "Enumeration")]
        if v.tag != "ScalarVariable" or len(typed) != 1:
            problems.append("%s: a ScalarVariable with one type element" % v.get("name"))
            continue
        key = (typed[0].tag, v.get("valueReference"))
        if key in seen:
            problems.append("%s: valueReference repeats within %s" % key)
        seen.add(key)
        if v.get("causality") not in ("parameter", "calculatedParameter", "input", "output", "local", "independent"):
            problems.append("%s: causality" % v.get("name"))
        if v.get("variability") not in ("constant", "fixed", "tunable", "discrete", "continuous"):
            problems.append("%s: variability" % v.get("name"))
        if v.get("causality") == "input" and typed[0].get("start") is None:
            problems.append("%s: an input needs a start value" % v.get("name"))
        if v.get("causality") == "output" and typed[0].get("start") is not None and v.get("initial") == "calculated":
            problems.append("%s: a calculated output has no start" % v.get("name"))
        if typed[0].get("unit") and typed[0].get("unit") not in units:
            problems.append("%s: unit not declared" % v.get("name"))
    outputs = [str(i + 1) for i, v in enumerate(variables) if v.get("causality") == "output"]
    structure = root.find("ModelStructure")
    listed = [u.get("index") for u in structure.find("Outputs")] if structure.find("Outputs") is not None else []
    initial = [u.get("index") for u in structure.find("InitialUnknowns")] if structure.find("InitialUnknowns") is not None else []
    if outputs != listed:
        problems.append("ModelStructure Outputs are not the outputs (1-based indices)")
    if initial != outputs:
        problems.append("InitialUnknowns are not the calculated outputs")
    return problems, float(root.find("DefaultExperiment").get("stepSize"))


def model_description_problems(fmu):
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        md = z.read("modelDescription.xml")
    problems = []
    root = ET.fromstring(md)
    if root.get("fmiVersion") == "2.0":
        return model_description_problems_2(root, names)
    if root.tag != "fmiModelDescription" or root.get("fmiVersion") != "3.0":
        problems.append("root element / fmiVersion")
    for a in ("modelName", "instantiationToken"):
        if not root.get(a):
            problems.append("fmiModelDescription without " + a)
    cs = root.find("CoSimulation")
    if cs is None or not cs.get("modelIdentifier"):
        problems.append("no CoSimulation modelIdentifier")
    elif "binaries/x86_64-linux/%s.so" % cs.get("modelIdentifier") not in names:
        problems.append("no binaries/x86_64-linux/<modelIdentifier>.so")
    units = {u.get("name") for u in root.iter("Unit")}
    variables = list(root.find("ModelVariables"))
    vrs = [v.get("valueReference") for v in variables]
    if len(vrs) != len(set(vrs)) or any(r is None or not r.isdigit() for r in vrs):
        problems.append("valueReferences not unique whole numbers")
    if sum(v.get("causality") == "independent" for v in variables) != 1:
        problems.append("not exactly one independent variable")
    for v in variables:
        if v.get("causality") not in ("parameter", "calculatedParameter", "input", "output", "local", "independent",
                                      "structuralParameter"):
            problems.append("%s: causality %s" % (v.get("name"), v.get("causality")))
        if v.get("variability") not in ("constant", "fixed", "tunable", "discrete", "continuous"):
            problems.append("%s: variability %s" % (v.get("name"), v.get("variability")))
        if v.get("unit") and v.get("unit") not in units:
            problems.append("%s: unit %s not declared" % (v.get("name"), v.get("unit")))
        if v.get("causality") == "independent" and (v.get("variability") != "continuous" or v.get("start")):
            problems.append("the independent variable must be continuous without start")
        if v.get("causality") == "input" and v.tag not in ("Binary", "Clock") and v.get("start") is None:
            problems.append("%s: an input needs a start value" % v.get("name"))
        if v.tag == "Binary" and v.get("causality") == "input" and v.find("Start") is None:
            problems.append("%s: a Binary input needs a <Start>" % v.get("name"))
        if v.tag == "Clock" and (v.get("variability") != "discrete" or
                                 v.get("intervalVariability") not in ("constant", "fixed", "tunable", "changing",
                                                                      "countdown", "triggered")):
            problems.append("%s: a Clock is discrete with an intervalVariability" % v.get("name"))
        if v.get("clocks"):
            clocks = {c.get("valueReference") for c in variables if c.tag == "Clock"}
            if any(c not in clocks for c in v.get("clocks").split()):
                problems.append("%s: clocks %s are not Clock variables" % (v.get("name"), v.get("clocks")))
        if v.tag == "Boolean" and (v.get("unit") or v.get("variability") == "continuous"):
            problems.append("%s: a Boolean has no unit and is not continuous" % v.get("name"))
    outputs = [v.get("valueReference") for v in variables if v.get("causality") == "output"]
    listed = [o.get("valueReference") for o in root.find("ModelStructure").iter("Output")]
    if outputs != listed:
        problems.append("ModelStructure Outputs are not the output variables")
    if root.find("DefaultExperiment") is None:
        problems.append("no DefaultExperiment")
    return problems, float(cs.get("fixedInternalStepSize")) if cs is not None else 0.0


def project(lines, columns):
    """The FMU's CSV lines cut to columns (a scenario's output.signals may record fewer)."""
    if not lines or not columns:
        return lines
    header = lines[0].split(",")
    if any(c not in header for c in columns):
        return lines
    at = [header.index(c) for c in columns]
    return [",".join(line.split(",")[i] for i in at) for line in lines]


def reference_rows(name, step, out):
    r = ehpt("run", name, "--quiet", "--set", "solver.duration_s=2", "--set", "output.interval_s=%r" % (10 * step),
             "--out", out)
    if r.returncode not in (0, 3):
        return None, r.stderr
    with open(os.path.join(out, "timeseries.csv")) as f:
        lines = f.read().splitlines()
    return [lines[0]] + lines[2:], ""  # the header, then every row after t = 0


def clean_run(files, args):
    """fmu_run ARGS where nothing of ehpt is reachable: the importer and FILES (name -> path)
    copied into a folder of their own, a mount namespace with an empty tmpfs over the source
    (and build) tree and an installed /usr/share/ehpt, the system's libtomlplusplus.so.3 hidden.
    Exits 77 (skipped) if this user cannot make a mount namespace."""
    box = tempfile.mkdtemp(dir="/tmp", prefix="ehpt-fmu-clean-")
    try:
        shutil.copy(FMU_RUN, os.path.join(box, "fmu_run"))
        for name, path in files.items():
            shutil.copy(path, os.path.join(box, name))
        hide = ["mount -t tmpfs none '%s'" % SRC]
        build = os.path.dirname(os.path.dirname(FMU_RUN))
        if not build.startswith(SRC + "/"):
            hide.append("mount -t tmpfs none '%s'" % build)
        if os.path.isdir("/usr/share/ehpt"):
            hide.append("mount -t tmpfs none /usr/share/ehpt")
        toml = "/usr/lib/x86_64-linux-gnu/libtomlplusplus.so.3"
        if os.path.exists(toml):
            hide.append("mount --bind /dev/null '%s'" % os.path.realpath(toml))
        run = "cd '%s' && exec ./fmu_run %s" % (box, " ".join("'%s'" % a for a in args))
        script = " && ".join(hide + ["test ! -e '%s/scenarios'" % SRC, run])
        r = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c", script],
                           capture_output=True, text=True, timeout=300)
        if r.returncode != 0 and ("Operation not permitted" in r.stderr or "unshare failed" in r.stderr):
            print("skipped: no mount namespace here: " + r.stderr.strip())
            sys.exit(77 if not failures else 1)
        return r
    finally:
        shutil.rmtree(box)


with tempfile.TemporaryDirectory() as tmp:
    names = [line.split()[0] for line in ehpt("list").stdout.splitlines() if line.strip()]
    check(len(names) >= 30, "the shipped scenarios: %d" % len(names))
    kinds = set()
    psecu2 = None
    for name in names:
        fmu = os.path.join(tmp, name + ".fmu")
        r = ehpt("fmu", name, "--set", "solver.duration_s=2", "--out", fmu)
        if r.returncode != 0:
            check(False, "%s: ehpt fmu (%d): %s" % (name, r.returncode, r.stderr[-300:]))
            continue
        with zipfile.ZipFile(fmu) as z:
            md_path = os.path.join(tmp, name + ".xml")
            with open(md_path, "wb") as f:
                f.write(z.read("modelDescription.xml"))
            vehicle = [n for n in z.namelist() if n.startswith("resources/vehicles/")]
        kinds.update(vehicle)
        lint = subprocess.run(["xmllint", "--noout", md_path], capture_output=True, text=True)
        problems, step = model_description_problems(fmu)
        check(lint.returncode == 0 and not problems, "%s: modelDescription.xml well formed and complete %s %s"
              % (name, lint.stderr[-200:], problems))
        want, err = reference_rows(name, step, os.path.join(tmp, "run_" + name))
        got = subprocess.run([FMU_RUN, fmu, "10", "2"], capture_output=True, text=True, timeout=300)
        rows = project(got.stdout.splitlines(), want[0].split(",") if want else [])
        same = want is not None and rows == want
        first = next((i for i, (a, b) in enumerate(zip(rows, want or [])) if a != b), None)
        check(same, "%s: the FMU's rows are ehpt run's (%d rows)%s" % (
            name, len(rows), "" if same else " first difference at row %s: %s | %s %s" % (
                first, rows[first][:120] if first is not None else "", (want or [""])[first or 0][:120],
                err + got.stderr[-300:])))
        if name == "psecu2_nedc":
            psecu2 = (fmu, want)
        # FMI 2.0: the same rows
        fmu2 = os.path.join(tmp, name + "_2.fmu")
        r = ehpt("fmu", name, "--fmi", "2", "--set", "solver.duration_s=2", "--out", fmu2)
        problems2, _ = model_description_problems(fmu2) if r.returncode == 0 else (["not built: " + r.stderr[-200:]], 0)
        got2 = subprocess.run([FMU_RUN, fmu2, "10", "2"], capture_output=True, text=True, timeout=300)
        rows2 = project(got2.stdout.splitlines(), want[0].split(",") if want else [])
        check(not problems2 and want is not None and rows2 == want,
              "%s: FMI 2.0: modelDescription complete %s, the same rows (%d)%s" % (
                  name, problems2, len(rows2), "" if rows2 == want else " " + got2.stderr[-300:]))
    check(len(kinds) >= 10, "FMUs of %d vehicle files: %s" % (len(kinds), sorted(kinds)))

    # --ecu none: the message fields as inputs and outputs, for both families; a rig has none
    for name, inputs in (("psecu2_nedc", 5), ("ev_nedc", 1)):
        fmu = os.path.join(tmp, name + "_plant.fmu")
        r = ehpt("fmu", name, "--ecu", "none", "--out", fmu)
        problems, _ = model_description_problems(fmu) if r.returncode == 0 else (["not built: " + r.stderr], 0)
        with zipfile.ZipFile(fmu) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        got = [v.get("name") for v in root.find("ModelVariables") if v.get("causality") == "input"]
        check(not problems and len(got) == inputs and all(n.startswith("command.") for n in got),
              "%s --ecu none: %d command inputs %s, complete %s" % (name, inputs, got, problems))
    r = ehpt("fmu", "battery_cc_discharge", "--ecu", "none", "--out", os.path.join(tmp, "rig.fmu"))
    check(r.returncode == 2 and "has no bus messages" in r.stderr and not os.path.exists(os.path.join(tmp, "rig.fmu")),
          "--ecu none on a rig: exit 2, why (%d): %s" % (r.returncode, r.stderr.strip()))

    # what ehpt fmu refuses: a path that is there (left as it was), FMI 1.0, a bad --set
    taken = os.path.join(tmp, "taken.fmu")
    with open(taken, "w") as f:
        f.write("mine")
    r = ehpt("fmu", "psecu2_nedc", "--out", taken)
    check(r.returncode == 2 and "is there already" in r.stderr and open(taken).read() == "mine",
          "--out over an existing file: exit 2, the file untouched (%d): %s" % (r.returncode, r.stderr.strip()))
    r = ehpt("fmu", "psecu2_nedc", "--fmi", "1", "--out", os.path.join(tmp, "one.fmu"))
    check(r.returncode == 2 and "3 (FMI 3.0) or 2 (FMI 2.0)" in r.stderr and not os.path.exists(os.path.join(tmp, "one.fmu")),
          "--fmi 1: exit 2, nothing written (%d): %s" % (r.returncode, r.stderr.strip()))
    r = ehpt("fmu", "psecu2_nedc", "--set", "vehicle.vehicle.mass_kg=-5", "--out", os.path.join(tmp, "bad.fmu"))
    check(r.returncode == 2 and "mass_kg" in r.stderr and not os.path.exists(os.path.join(tmp, "bad.fmu")),
          "a bad --set: exit 2 with the load message, nothing written (%d): %s" % (r.returncode, r.stderr.strip()[-200:]))

    if CLEAN and psecu2 is not None:
        r = clean_run({"p.fmu": psecu2[0]}, ["p.fmu", "10", "2"])
        check(r.returncode == 0 and project(r.stdout.splitlines(), psecu2[1][0].split(",")) == psecu2[1],
              "psecu2_nedc where nothing of ehpt is reachable (trees and libtomlplusplus hidden): the same rows (%d): %s"
              % (r.returncode, r.stderr[-400:]))

def ls_bus_problems(fmu):
    """What FMI-LS-BUS asks of a Low-Cut CAN FMU beyond FMI 3.0."""
    problems, _ = model_description_problems(fmu)
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
        names = set(z.namelist())
        terminals = ET.fromstring(z.read("terminalsAndIcons/terminalsAndIcons.xml")) \
            if "terminalsAndIcons/terminalsAndIcons.xml" in names else None
    if root.find("CoSimulation").get("hasEventMode") != "true":
        problems.append("hasEventMode must be true")
    bus = {v.get("name"): v for v in root.find("ModelVariables") if v.tag in ("Binary", "Clock")}
    want = {"CAN.Rx_Data": ("Binary", "input"), "CAN.Rx_Clock": ("Clock", "input"),
            "CAN.Tx_Data": ("Binary", "output"), "CAN.Tx_Clock": ("Clock", "output")}
    for name, (tag, causality) in want.items():
        v = bus.get(name)
        if v is None or v.tag != tag or v.get("causality") != causality:
            problems.append("%s: a %s %s" % (name, causality, tag))
        elif tag == "Clock" and v.get("intervalVariability") != "triggered":
            problems.append("%s: triggered" % name)
        elif tag == "Binary" and not v.get("mimeType", "").startswith("application/org.fmi-standard.fmi-ls-bus.can"):
            problems.append("%s: the LS-BUS CAN MIME type" % name)
    if len(bus) == 4 and bus["CAN.Rx_Data"].get("clocks") != bus["CAN.Rx_Clock"].get("valueReference"):
        problems.append("Rx_Data is clocked by Rx_Clock")
    if len(bus) == 4 and bus["CAN.Tx_Data"].get("clocks") != bus["CAN.Tx_Clock"].get("valueReference"):
        problems.append("Tx_Data is clocked by Tx_Clock")
    if terminals is None:
        problems.append("no terminalsAndIcons/terminalsAndIcons.xml")
    else:
        t = terminals.find("Terminals/Terminal")
        members = {m.get("memberName"): m.get("variableName") for m in t.iter("TerminalMemberVariable")} if t is not None else {}
        if t is None or t.get("terminalKind") != "org.fmi-ls-bus.network-terminal" or \
                t.get("matchingRule") != "org.fmi-ls-bus.transceiver" or \
                members != {m: "CAN." + m for m in ("Rx_Data", "Rx_Clock", "Tx_Data", "Tx_Clock")}:
            problems.append("the terminal: kind, matching rule, the four members %s" % members)
    for f in ("extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml", "extra/org.fmi-standard.fmi-ls-bus/ehpt.dbc"):
        if f not in names:
            problems.append("no " + f)
    return problems


def wait_listening(port, proc, timeout_s=20.0):
    deadline = time.time() + timeout_s
    while time.time() < deadline and proc.poll() is None:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return True
        except OSError:
            time.sleep(0.05)
    return False


with tempfile.TemporaryDirectory() as tmp:
    # --bus ls-bus: the plant and its ECU as two FMUs on one CAN bus, against a socketcand session
    dur = "solver.duration_s=12"  # NEDC's first acceleration (from 11 s): the ECU's commands move the car
    plant_fmu, ecu_fmu = os.path.join(tmp, "plant.fmu"), os.path.join(tmp, "ecu.fmu")
    r1 = ehpt("fmu", "psecu2_nedc", "--bus", "ls-bus", "--set", dur, "--out", plant_fmu)
    r2 = ehpt("fmu", "psecu2_nedc", "--bus", "ls-bus", "--role", "ecu", "--set", dur, "--out", ecu_fmu)
    check(r1.returncode == 0 and r2.returncode == 0, "ehpt fmu --bus ls-bus: the plant and the ECU (%d, %d) %s"
          % (r1.returncode, r2.returncode, (r1.stderr + r2.stderr)[-300:]))
    if r1.returncode == 0 and r2.returncode == 0:
        for fmu in (plant_fmu, ecu_fmu):
            with zipfile.ZipFile(fmu) as z:
                for member in ("modelDescription.xml", "terminalsAndIcons/terminalsAndIcons.xml",
                               "extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml"):
                    path = os.path.join(tmp, "lint.xml")
                    with open(path, "wb") as f:
                        f.write(z.read(member))
                    lint = subprocess.run(["xmllint", "--noout", path], capture_output=True, text=True)
                    check(lint.returncode == 0, "%s: %s well formed %s" % (os.path.basename(fmu), member, lint.stderr[-200:]))
            problems = ls_bus_problems(fmu)
            check(not problems, "%s: FMI 3.0 and FMI-LS-BUS complete %s" % (os.path.basename(fmu), problems))
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        session = os.path.join(tmp, "session")
        bus = "socketcand:127.0.0.1:%d" % port
        with open(os.path.join(tmp, "plant.log"), "w") as plog, open(os.path.join(tmp, "ecu.log"), "w") as elog:
            plant = subprocess.Popen([EHPT, "plant", "psecu2_nedc", "--bus", bus, "--lockstep", "--quiet", "--out", session,
                                      "--set", dur, "--set", "output.interval_s=0.01"], stdout=plog, stderr=plog)
            listening = wait_listening(port, plant)
            ecu = subprocess.Popen([EHPT, "ecu", "psecu2_nedc", "--bus", bus], stdout=elog, stderr=elog)
            plant_rc, ecu_rc = plant.wait(timeout=300), ecu.wait(timeout=300)
        with open(os.path.join(tmp, "plant.log")) as f:
            plant_text = f.read()
        check(listening and plant_rc == 0 and ecu_rc == 0, "the lockstep socketcand session (%d, %d): %s"
              % (plant_rc, ecu_rc, plant_text[-300:]))
        lines = open(os.path.join(session, "timeseries.csv")).read().splitlines() if plant_rc == 0 else []
        want = [lines[0]] + lines[2:] if lines else None  # the header, then every sample after t = 0
        got = subprocess.run([FMU_RUN, plant_fmu, "10", "12", ecu_fmu], capture_output=True, text=True, timeout=300)
        rows = project(got.stdout.splitlines(), want[0].split(",") if want else [])
        first = next((i for i, (a, b) in enumerate(zip(rows, want or [])) if a != b), None)
        check(got.returncode == 0 and want is not None and rows == want and len(rows) == 1201,
              "plant FMU + ECU FMU, Tx_Data to Rx_Data: the socketcand lockstep session's rows (%d of %d)%s %s"
              % (len(rows), len(want or []), "" if first is None else " first difference at row %d: %s | %s" % (
                  first, rows[first][:100], want[first][:100]), got.stderr[-300:]))
        check("1201 event modes, 2402 transfers" in got.stderr and "fmi3Terminate OK" in got.stderr,
              "every sample crossed the bus both ways, the session OK: %s" % got.stderr.strip()[-200:])
        if CLEAN:
            r = clean_run({"plant.fmu": plant_fmu, "ecu.fmu": ecu_fmu}, ["plant.fmu", "10", "12", "ecu.fmu"])
            check(r.returncode == 0 and want is not None and project(r.stdout.splitlines(), want[0].split(",")) == want,
                  "the plant and ECU FMUs where nothing of ehpt is reachable: the same rows (%d): %s"
                  % (r.returncode, r.stderr[-300:]))
        alone = subprocess.run([FMU_RUN, plant_fmu, "10", "12"], capture_output=True, text=True, timeout=300)
        check(alone.returncode == 0 and "fmi3Terminate Warning" in alone.stderr and "no ECU" in alone.stderr,
              "the plant FMU without its ECU: fmi3Terminate is a Warning that says no ECU: %s" % alone.stderr.strip()[-300:])
    # the series hybrid's pair: plant and EMS as FMUs on ShevSensors/ShevCommand, through the genset's
    # start at 267.31 s: every 0.1 s row equals `ehpt run` through the CAN codec
    sdur = "solver.duration_s=300"
    splant, secu = os.path.join(tmp, "shev_plant.fmu"), os.path.join(tmp, "shev_ecu.fmu")
    r1 = ehpt("fmu", "shev_oo_sort1", "--bus", "ls-bus", "--set", sdur, "--out", splant)
    r2 = ehpt("fmu", "shev_oo_sort1", "--bus", "ls-bus", "--role", "ecu", "--set", sdur, "--out", secu)
    r3 = ehpt("run", "shev_oo_sort1", "--set", sdur, "--set", "vehicle.ecu.codec=can", "--quiet",
              "--out", os.path.join(tmp, "shev_ref"))
    check(r1.returncode == 0 and r2.returncode == 0 and r3.returncode == 0,
          "the series hybrid's plant and EMS FMUs (%d, %d, %d) %s" % (r1.returncode, r2.returncode, r3.returncode,
                                                                     (r1.stderr + r2.stderr + r3.stderr)[-300:]))
    if r1.returncode == 0 and r2.returncode == 0 and r3.returncode == 0:
        for fmu in (splant, secu):
            problems = ls_bus_problems(fmu)
            check(not problems, "%s: FMI 3.0 and FMI-LS-BUS complete %s" % (os.path.basename(fmu), problems))
        got = subprocess.run([FMU_RUN, splant, "10", "300", secu], capture_output=True, text=True, timeout=300)
        ref = open(os.path.join(tmp, "shev_ref", "timeseries.csv")).read().splitlines()
        by_time = {line.split(",", 1)[0]: line for line in got.stdout.splitlines()[1:]}
        rows = [by_time.get(line.split(",", 1)[0]) for line in ref[2:]]  # every 0.1 s after t = 0
        same = sum(1 for a, b in zip(rows, ref[2:]) if a == b)
        on = ref[0].split(",").index("genset_on")
        check(got.returncode == 0 and got.stdout.splitlines()[0] == ref[0] and same == len(ref) - 2 == 3000 and
              float(ref[-1].split(",")[on]) == 1.0,
              "the series hybrid's plant FMU + EMS FMU: every row of ehpt run through the codec (%d of %d), the genset "
              "on at the end %s" % (same, len(ref) - 2, got.stderr[-300:]))
        check("30001 event modes, 60002 transfers" in got.stderr, "... every sample both ways: %s" % got.stderr[-200:])
    r = ehpt("fmu", "psecu2_nedc", "--bus", "ls-bus", "--fmi", "2", "--out", os.path.join(tmp, "two.fmu"))
    check(r.returncode == 2 and "FMI 3.0" in r.stderr and not os.path.exists(os.path.join(tmp, "two.fmu")),
          "--bus ls-bus --fmi 2: exit 2, why, nothing written (%d): %s" % (r.returncode, r.stderr.strip()))
    r = ehpt("fmu", "battery_cc_discharge", "--bus", "ls-bus", "--out", os.path.join(tmp, "rigbus.fmu"))
    check(r.returncode == 2 and "has no bus messages" in r.stderr, "--bus ls-bus on a rig: exit 2, why (%d): %s"
          % (r.returncode, r.stderr.strip()))
    r = ehpt("fmu", "psecu2_nedc", "--role", "ecu", "--out", os.path.join(tmp, "ecu_nobus.fmu"))
    check(r.returncode == 2 and "--bus ls-bus" in r.stderr, "--role ecu without --bus: exit 2, why (%d): %s"
          % (r.returncode, r.stderr.strip()))

print("ok" if not failures else "%d check(s) failed" % len(failures))
sys.exit(1 if failures else 0)
