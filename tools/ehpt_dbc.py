# SPDX-License-Identifier: BSD-3-Clause
"""A tiny reader of ehpt's CAN contract (io/can/ehpt.dbc), standard library only.

It reads the BO_ (message) and SG_ (signal) lines and nothing else, and it knows only what
the contract uses: classic 8-byte frames, 11-bit ids, little-endian (Intel, "@1") signals
without multiplexing. Anything else in a BO_/SG_ line is refused at load time, so a changed
contract fails loudly here instead of producing wrong numbers on the bus.

    dbc = Dbc("io/can/ehpt.dbc")
    can_id, data = dbc.encode("EvCommand", {"driveTauRef_Nm": 12.5}, counter=3)
    name, signals = dbc.decode(can_id, data)   # ("EvCommand", {"driveTauRef_Nm": 12.5, "counter": 3})
"""

import math
import re
from dataclasses import dataclass, field

_BO = re.compile(r"^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+(\w+)\s*$")
#                   SG_ name      : start | len  @ order sign   (factor , offset)    [min | max]   "unit"  receivers
_SG = re.compile(r"^SG_\s+(\w+)\s*:\s*(\d+)\|(\d+)@([01])([+-])\s*\(([^,()]+),([^,()]+)\)\s*"
                 r"\[([^|\]]+)\|([^|\]]+)\]\s*\"([^\"]*)\"")


@dataclass
class Signal:
    name: str
    start: int       # bit i of the little-endian payload integer
    length: int
    signed: bool     # two's complement in `length` bits
    factor: float
    offset: float
    minimum: float
    maximum: float
    unit: str

    def raw_limits(self):
        if self.signed:
            return -(1 << (self.length - 1)), (1 << (self.length - 1)) - 1
        return 0, (1 << self.length) - 1

    def to_raw(self, value):
        """Physical -> raw: clamp to [min, max], scale, round half away from zero (like C++ lround)."""
        if math.isnan(value):
            raise ValueError(f"signal {self.name}: value {value!r} is not a number")
        value = min(max(float(value), self.minimum), self.maximum)
        scaled = (value - self.offset) / self.factor
        raw = int(math.copysign(math.floor(abs(scaled) + 0.5), scaled))
        lo, hi = self.raw_limits()  # [min, max] should fit already; never wrap around if it does not
        return min(max(raw, lo), hi)

    def to_physical(self, raw):
        if self.factor == int(self.factor) and self.offset == int(self.offset):
            return int(raw * self.factor + self.offset)  # counters, step indices, flags stay ints
        return raw * self.factor + self.offset


@dataclass
class Message:
    id: int
    name: str
    length: int      # bytes
    sender: str
    signals: list = field(default_factory=list)


class Dbc:
    def __init__(self, path):
        self.by_name, self.by_id = {}, {}
        current = None
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                line = line.strip()
                where = f"{path}:{number}"
                if line.startswith("BO_ "):
                    m = _BO.match(line)
                    if not m:
                        raise ValueError(f"{where}: cannot read message line: {line}")
                    current = Message(int(m[1]), m[2], int(m[3]), m[4])
                    if current.id > 0x7FF or current.length > 8 or current.id in self.by_id:
                        raise ValueError(f"{where}: need a new 11-bit id and at most 8 bytes: {line}")
                    self.by_name[current.name] = self.by_id[current.id] = current
                elif line.startswith("SG_ "):
                    m = _SG.match(line)
                    if not m or current is None:
                        raise ValueError(f"{where}: cannot read signal line (multiplexed?): {line}")
                    if m[4] != "1":
                        raise ValueError(f"{where}: only little-endian (@1) signals are supported: {line}")
                    s = Signal(m[1], int(m[2]), int(m[3]), m[5] == "-", float(m[6]), float(m[7]),
                               float(m[8]), float(m[9]), m[10])
                    used = 0
                    for other in current.signals:
                        used |= ((1 << other.length) - 1) << other.start
                    mine = ((1 << s.length) - 1) << s.start
                    if s.length < 1 or s.start + s.length > 8 * current.length or used & mine or s.factor == 0:
                        raise ValueError(f"{where}: signal {s.name} overlaps, leaves the frame or has factor 0")
                    current.signals.append(s)
                elif line:
                    current = None  # a signal line must follow its message directly

    def encode(self, message_name, values, counter):
        """-> (id, bytes). `values` must give every signal except `counter`; values are clamped."""
        msg = self.by_name.get(message_name)
        if msg is None:
            raise ValueError(f"unknown message {message_name!r}")
        names = {s.name for s in msg.signals}
        unknown = set(values) - names
        missing = names - set(values) - {"counter"}
        if unknown or missing or "counter" in values:
            raise ValueError(f"{message_name}: unknown signals {sorted(unknown)}, missing {sorted(missing)}"
                             + (", counter goes in the counter argument" if "counter" in values else ""))
        if not 0 <= counter <= 15:
            raise ValueError(f"{message_name}: counter {counter} outside 0..15")
        payload = 0
        for s in msg.signals:
            raw = counter if s.name == "counter" else s.to_raw(values[s.name])
            payload |= (raw & ((1 << s.length) - 1)) << s.start  # & mask: two's complement for raw < 0
        return msg.id, payload.to_bytes(msg.length, "little")

    def decode(self, can_id, data):
        """-> (message name, {signal: physical value}), `counter` included."""
        msg = self.by_id.get(can_id)
        if msg is None:
            raise ValueError(f"unknown CAN id {can_id} (0x{can_id:X}): not in the DBC")
        if len(data) != msg.length:
            raise ValueError(f"{msg.name} (id {can_id}): {len(data)} data bytes, the DBC says {msg.length}")
        payload = int.from_bytes(bytes(data), "little")
        out = {}
        for s in msg.signals:
            raw = (payload >> s.start) & ((1 << s.length) - 1)
            if s.signed and raw >> (s.length - 1):
                raw -= 1 << s.length  # sign extension
            out[s.name] = s.to_physical(raw)
        return msg.name, out
