#!/bin/sh
# SPDX-License-Identifier: BSD-3-Clause
# Runs COMMAND in a private network namespace whose loopback carries multicast (LCM udpm):
# no packet of the test can leave it. 77 (skipped) where namespaces cannot be made.
# usage: tests/targets/in_netns.sh COMMAND [ARGS...]
if ! unshare -n true 2>/dev/null; then
  echo "in_netns: cannot create a network namespace here (needs root or user namespaces)" >&2
  exit 77
fi
exec unshare -n sh -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$@"' in_netns "$@"
