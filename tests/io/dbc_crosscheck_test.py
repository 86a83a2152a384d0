#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""ehpt's DBC reader (io/can/dbc.cpp) against a third-party one: python3-canmatrix.

    /usr/bin/python3 tests/io/dbc_crosscheck_test.py EHPT DBC...

For every DBC given (tests/io/dbc/: one per feature: Intel and Motorola, signed, scaling in
exponent notation, extended ids, CAN FD payloads, multiplexing, IEEE floats, attributes):
- the messages and signals `ehpt dbc FILE --json` lists equal canmatrix's, field by field
  (id, extended, FD, size, sender, cycle time, send type, comment; each signal's length, byte
  order, sign and type, factor, offset, min, max, unit, receivers, multiplexing, value names);
- on random payloads (fixed seed; a multiplexor mostly set to one of its message's mux
  values), every signal `ehpt dbc FILE --json --frames -` decodes equals canmatrix's decode,
  value by value (raw exactly; physical to 1e-12 relative, NaN as NaN), and the set of
  signals present in each frame is the same.
Exit 0 if every check passed, 1 otherwise.
"""

import json
import math
import os
import random
import subprocess
import sys

import canmatrix.formats

PAYLOADS_PER_MESSAGE = 200
failures = []


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAIL " + what)


def canmatrix_frames(path):
    db = canmatrix.formats.loadp_flat(path)
    return db, {(f.arbitration_id.id, bool(f.arbitration_id.extended)): f for f in db.frames}


def attribute(db, obj, name, defines):
    """An attribute as the DBC means it: the object's own value, else BA_DEF_DEF_'s default."""
    if name in obj.attributes:
        return obj.attributes[name]
    define = defines.get(name)
    return define.defaultValue if define is not None else None


def ours(ehpt, path, frames=None):
    args = [ehpt, "dbc", path, "--json"] + (["--frames", "-"] if frames is not None else [])
    r = subprocess.run(args, input="\n".join(frames or []) + "\n", capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        sys.exit(f"ehpt dbc {path}: exit {r.returncode}\n{r.stderr}")
    if frames is None:
        return json.loads(r.stdout)["messages"]
    return [json.loads(line) for line in r.stdout.splitlines() if line.strip()]


def same_number(a, b):
    if a is None or b is None:  # JSON null is NaN
        return (a is None or math.isnan(a)) and (b is None or math.isnan(b))
    a, b = float(a), float(b)
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= 1e-12 * max(1.0, abs(a), abs(b))


def compare_metadata(db, name, ours_message, theirs):
    m = ours_message
    check(m["size_bytes"] == theirs.size, f"{name}: size {m['size_bytes']} vs {theirs.size}")
    check(m["fd"] == bool(theirs.is_fd), f"{name}: fd {m['fd']} vs {theirs.is_fd}")
    check(m["senders"] == list(theirs.transmitters) or (m["senders"] == ["Vector__XXX"] and not theirs.transmitters),
          f"{name}: senders {m['senders']} vs {theirs.transmitters}")
    cycle = attribute(db, theirs, "GenMsgCycleTime", db.frame_defines)
    cycle = int(cycle) if cycle not in (None, "", "0", 0) else None
    check(m["cycle_time_ms"] == cycle, f"{name}: cycle time {m['cycle_time_ms']} vs {cycle}")
    send_type = attribute(db, theirs, "GenMsgSendType", db.frame_defines)
    define = db.frame_defines.get("GenMsgSendType")
    if send_type is not None and define is not None and str(send_type).isdigit():  # an ENUM index
        send_type = define.values[int(send_type)]
    check(m["send_type"] == (send_type or "").strip('"'), f"{name}: send type {m['send_type']!r} vs {send_type!r}")
    check(m["comment"] == (theirs.comment or ""), f"{name}: comment {m['comment']!r} vs {theirs.comment!r}")
    theirs_signals = {s.name: s for s in theirs.signals}
    check(sorted(s["name"] for s in m["signals"]) == sorted(theirs_signals),
          f"{name}: signals {[s['name'] for s in m['signals']]} vs {sorted(theirs_signals)}")
    for s in m["signals"]:
        t = theirs_signals.get(s["name"])
        if t is None:
            continue
        where = f"{name}.{s['name']}"
        check(s["length"] == t.size, f"{where}: length {s['length']} vs {t.size}")
        check((s["byte_order"] == "Intel") == bool(t.is_little_endian), f"{where}: byte order {s['byte_order']}")
        check((s["type"] in ("float", "double")) == bool(t.is_float), f"{where}: float {s['type']} vs {t.is_float}")
        if s["type"] in ("signed", "unsigned"):
            check((s["type"] == "signed") == bool(t.is_signed), f"{where}: sign {s['type']} vs {t.is_signed}")
        for key, value in (("factor", t.factor), ("offset", t.offset)):
            check(same_number(s[key], value), f"{where}: {key} {s[key]} vs {value}")
        # canmatrix computes a range from the bits when the DBC gives [0|0]
        if s["min"] != 0 or s["max"] != 0:
            check(same_number(s["min"], t.min) and same_number(s["max"], t.max),
                  f"{where}: range [{s['min']}, {s['max']}] vs [{t.min}, {t.max}]")
        check(s["unit"] == (t.unit or ""), f"{where}: unit {s['unit']!r} vs {t.unit!r}")
        check(s["receivers"] == list(t.receivers), f"{where}: receivers {s['receivers']} vs {t.receivers}")
        mux = "M" if t.is_multiplexer else (f"m{t.mux_val}" if t.mux_val is not None else "")
        check(s["multiplex"] == mux, f"{where}: multiplex {s['multiplex']!r} vs {mux!r}")
        names = {v["raw"]: v["name"] for v in s["value_names"]}
        check(names == {int(k): v for k, v in t.values.items()}, f"{where}: value names {names} vs {t.values}")
        check(s["comment"] == (t.comment or ""), f"{where}: comment {s['comment']!r} vs {t.comment!r}")
        theirs_start = attribute(db, t, "GenSigStartValue", db.signal_defines)
        check((s["start_value_raw"] is None and theirs_start is None) or
              (theirs_start is not None and same_number(s["start_value_raw"], float(theirs_start))),
              f"{where}: start value {s['start_value_raw']} vs {theirs_start}")


def payloads(rng, message, theirs):
    """Random payloads; a multiplexor set to one of the message's mux values most of the time."""
    size = message["size_bytes"]
    mux_values = sorted({s.mux_val for s in theirs.signals if s.mux_val is not None})
    multiplexor = next((s for s in theirs.signals if s.is_multiplexer), None)
    out = []
    for k in range(PAYLOADS_PER_MESSAGE):
        data = bytearray(rng.getrandbits(8) for _ in range(size))
        if k % 10 == 0:  # edge patterns: all zeros, all ones
            data = bytearray([0x00 if k % 20 == 0 else 0xFF] * size)
        if multiplexor is not None and mux_values and k % 5 != 4:
            theirs.signal_by_name(multiplexor.name)
            encoded = theirs.encode({s.name: 0 for s in theirs.signals if s.mux_val is None and not s.is_multiplexer}
                                    | {multiplexor.name: rng.choice(mux_values)})
            # keep the random bits, take the multiplexor's bits from the encoded frame
            mask = theirs.encode({multiplexor.name: (1 << multiplexor.size) - 1}
                                 | {s.name: 0 for s in theirs.signals if s.mux_val is None and not s.is_multiplexer})
            data = bytearray((d & ~m) | (e & m) for d, e, m in zip(data, encoded, mask))
        out.append(bytes(data))
    return out


def frame_text(message, data):
    ident = f"{message['id']:08X}" if message["extended"] else f"{message['id']:03X}"
    return f"{ident}##0{data.hex().upper()}" if message["fd"] else f"{ident}#{data.hex().upper()}"


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    ehpt = sys.argv[1]
    rng = random.Random(20261202)
    for path in sys.argv[2:]:
        base = os.path.basename(path)
        db, theirs = canmatrix_frames(path)
        messages = ours(ehpt, path)
        check(sorted((m["id"], m["extended"]) for m in messages) == sorted(theirs),
              f"{base}: messages {[(m['id'], m['extended']) for m in messages]} vs {sorted(theirs)}")
        frames, expected = [], []
        for m in messages:
            t = theirs.get((m["id"], m["extended"]))
            if t is None:
                continue
            compare_metadata(db, f"{base} {m['name']}", m, t)
            for data in payloads(rng, m, t):
                frames.append(frame_text(m, data))
                expected.append((m, t.decode(bytearray(data))))
        decoded = ours(ehpt, path, frames)
        check(len(decoded) == len(frames), f"{base}: {len(decoded)} frames decoded of {len(frames)}")
        compared = 0
        for (m, want), got, frame in zip(expected, decoded, frames):
            where = f"{base} {m['name']} {frame}"
            check(sorted(got["signals"]) == sorted(want), f"{where}: present {sorted(got['signals'])} vs {sorted(want)}")
            for name, value in got["signals"].items():
                w = want.get(name)
                if w is None:
                    continue
                compared += 1
                if "raw" in value:
                    check(value["raw"] == int(w.raw_value), f"{where}: {name} raw {value['raw']} vs {w.raw_value}")
                check(same_number(value["value"], w.phys_value),
                      f"{where}: {name} = {value['value']} vs {w.phys_value}")
        print(f"{base}: {len(messages)} messages, {len(frames)} frames, {compared} signal values compared")
        check(compared > 0, f"{base}: nothing compared")
    if failures:
        print(f"{len(failures)} checks failed")
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
