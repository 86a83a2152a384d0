#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""A listener that knows only the Linux SocketCAN API (linux/can/error.h): a raw CAN socket on
an interface with every error class let through; writes each error frame it hears as
"CAN_ID_HEX DATA_HEX" lines to OUT, until IDLE_S seconds pass with no frame at all (data or
error) after the first one, or MAX_S in all. Once bound it creates OUT.ready, so a caller can
start the sender only when nothing it sends can be missed (python starts slowly under TCG).

    vcan_error_listener.py INTERFACE OUT IDLE_S MAX_S
"""
import socket
import struct
import sys
import time

CAN_ERR_FLAG = 0x20000000
CAN_ERR_MASK = 0x1FFFFFFF
CAN_RAW_ERR_FILTER = 2
FRAME = struct.Struct("=IB3x8s")  # struct can_frame

interface, out_path, idle_s, max_s = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
s.setsockopt(socket.SOL_CAN_RAW, CAN_RAW_ERR_FILTER, struct.pack("=I", CAN_ERR_MASK))
s.bind((interface,))
open(out_path + ".ready", "w").close()
s.settimeout(0.5)
start = time.monotonic()
last = None
lines = []
while time.monotonic() - start < max_s:
    try:
        raw = s.recv(FRAME.size)
    except socket.timeout:
        if last is not None and time.monotonic() - last > idle_s:
            break
        continue
    last = time.monotonic()
    can_id, length, data = FRAME.unpack(raw)
    if can_id & CAN_ERR_FLAG:
        lines.append("%08X %s" % (can_id, data[:length].hex().upper()))
with open(out_path, "w") as f:
    f.write("".join(line + "\n" for line in lines))
