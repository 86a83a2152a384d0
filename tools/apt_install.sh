#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# apt-get installs those of the given Debian packages that are missing (as root, or with sudo).
# usage: tools/apt_install.sh LABEL PACKAGE...   (LABEL names the caller in its message)
set -euo pipefail
label="$1"
shift
missing=()
for p in "$@"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "$label: installing ${missing[*]}" >&2
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi
