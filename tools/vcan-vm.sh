#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Runs one command where a real SocketCAN vcan0 exists, even on a host kernel without CAN.
#
# usage: tools/vcan-vm.sh [--out DIR] [--timeout SECONDS] -- COMMAND [ARGS...]
#
# If the host kernel can create a vcan device, COMMAND runs here directly with vcan0 up.
# Otherwise it runs in a throw-away qemu guest (Debian's plain -amd64 kernel, TCG) with the
# modules can, can-raw, can-bcm, can-dev and vcan loaded and vcan0 up. The guest sees the
# host's root read-only under a tmpfs overlay (same paths, /work and /tmp included; its
# writes vanish), starts in the same working directory with the same environment, and has
# DIR mounted writable at the same absolute path, so outputs written there outlive the guest.
# Facts behind every choice here: ../shared/reference/VCAN-VM.md.
#
# COMMAND's stdout and stderr reach ours (after it ends, not streamed; stdin is /dev/null),
# and we exit with its code. 124: timeout (default 600 s, qemu is killed). 77 (one line on
# stderr): qemu cannot run here (no qemu, no kernel). 125: the guest ended without running
# COMMAND (see the console log). Kernel and boot messages go to DIR/vcan-vm-console.log.
#
# Cache: ${EHPT_VCAN_CACHE:-$HOME/.cache/ehpt-vcan-vm} holds the kernel, vmlinux, modules and
# initramfs (first run downloads ~70 MB). EHPT_VCAN_FORCE_VM=1 uses the guest even when the
# host has vcan; EHPT_VCAN_VM_MEMORY_MB (default 1024) and EHPT_VCAN_VM_CPUS (default 2) size it.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cache="${EHPT_VCAN_CACHE:-$HOME/.cache/ehpt-vcan-vm}"
timeout_s=600
out_dir=""

usage() {
  echo "usage: tools/vcan-vm.sh [--out DIR] [--timeout SECONDS] -- COMMAND [ARGS...]" >&2
  exit 2
}
cannot_run() {
  echo "vcan-vm: cannot run qemu here: $*" >&2
  exit 77
}

while [ $# -gt 0 ]; do
  case "$1" in
    --out) [ $# -ge 2 ] || usage; out_dir="$2"; shift 2 ;;
    --timeout) [ $# -ge 2 ] || usage; timeout_s="$2"; shift 2 ;;
    --) shift; break ;;
    *) usage ;;
  esac
done
[ $# -ge 1 ] || usage
[[ "$timeout_s" =~ ^[1-9][0-9]*$ ]] || { echo "vcan-vm: --timeout $timeout_s: expected whole seconds > 0" >&2; exit 2; }

# Everything this process creates for itself and removes again (never anything else).
own_temp=()
qemu_pid=""
cleanup() {
  if [ -n "$qemu_pid" ]; then kill "$qemu_pid" 2>/dev/null || true; fi
  if [ ${#own_temp[@]} -gt 0 ]; then rm -rf -- "${own_temp[@]}"; fi
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# --- host path: the kernel has vcan (root needed to create links) -----------------------
host_has_vcan() {
  command -v ip >/dev/null || return 1
  ip link add dev vcan-probe type vcan 2>/dev/null || return 1
  ip link delete dev vcan-probe 2>/dev/null || true
}
if [ "${EHPT_VCAN_FORCE_VM:-0}" != 1 ] && host_has_vcan; then
  echo "vcan-vm: host kernel has vcan; running the command here" >&2
  created_vcan0=0
  if ! ip link show dev vcan0 >/dev/null 2>&1; then
    ip link add dev vcan0 type vcan
    created_vcan0=1
  fi
  ip link set up vcan0
  [ -z "$out_dir" ] || mkdir -p -- "$out_dir"
  rc=0
  timeout "$timeout_s" "$@" || rc=$?
  # only the vcan0 we made goes away again
  if [ "$created_vcan0" = 1 ]; then ip link delete dev vcan0 || true; fi
  if [ "$rc" = 124 ]; then echo "vcan-vm: timeout after $timeout_s s" >&2; fi
  exit "$rc"
fi

# --- guest path ------------------------------------------------------------------------
echo "vcan-vm: host kernel has no vcan; running the command in a qemu guest" >&2

# tools this needs (apt failures are not fatal here: what is still missing decides)
"$here/apt_install.sh" vcan-vm qemu-system-x86 busybox-static iproute2 can-utils xz-utils \
  || echo "vcan-vm: apt-get install failed; trying with what is installed" >&2
command -v qemu-system-x86_64 >/dev/null || cannot_run "no qemu-system-x86_64 (apt install qemu-system-x86 failed)"
[ -x /bin/busybox ] || cannot_run "no /bin/busybox (apt install busybox-static failed)"

# In dependency order (no modules.dep in the .deb, so no modprobe). A module that is not in
# the package is taken to be built in.
modules=(virtio_ring virtio virtio_pci_modern_dev virtio_pci_legacy_dev virtio_pci netfs fscache
         9pnet 9pnet_virtio 9p overlay can can-raw can-bcm can-dev vcan)

# Kernel, ELF vmlinux and modules, once per kernel version. Built in a temporary folder and
# renamed into place, so parallel first runs cannot see half a cache.
newest_kernel_dir() {
  local d best=""
  for d in "$cache"/kernel-*; do
    [ -f "$d/complete" ] && best="$d"
  done
  printf '%s' "$best"
}
fetch_kernel() {
  local pkg work kver f off m
  pkg="$(apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/^ *Depends: \(linux-image-[0-9].*-amd64\)$/\1/p' | head -n 1)"
  if [ -z "$pkg" ]; then
    apt-get update -qq >/dev/null 2>&1 || true
    pkg="$(apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/^ *Depends: \(linux-image-[0-9].*-amd64\)$/\1/p' | head -n 1)"
  fi
  [ -n "$pkg" ] || cannot_run "kernel download failed (apt-cache knows no linux-image-amd64)"
  kver="${pkg#linux-image-}"
  mkdir -p -- "$cache"
  work="$(mktemp -d "$cache/.fetch.XXXXXX")"
  own_temp+=("$work")
  echo "vcan-vm: downloading $pkg into $cache (once)" >&2
  (cd "$work" && apt-get download -qq "$pkg" >/dev/null 2>&1) || cannot_run "kernel download failed (apt-get download $pkg)"
  dpkg -x "$work"/"$pkg"_*.deb "$work/root" || cannot_run "kernel download failed (dpkg -x $pkg)"
  mkdir -p "$work/kernel/modules"
  cp "$work/root/boot/vmlinuz-$kver" "$work/kernel/vmlinuz"
  for m in "${modules[@]}"; do
    f="$(find "$work/root/lib/modules/$kver" -name "$m.ko" -o -name "$m.ko.xz" -o -name "$m.ko.zst" | head -n 1)"
    case "$f" in
      "") ;;
      *.ko.xz) xz -dc "$f" >"$work/kernel/modules/$m.ko" ;;
      *.ko.zst) zstd -qdc "$f" >"$work/kernel/modules/$m.ko" ;;
      *) cp "$f" "$work/kernel/modules/$m.ko" ;;
    esac
  done
  # The ELF vmlinux inside the xz payload boots directly (PVH), ~3 s faster under TCG than
  # letting the bzImage decompress itself. xz complains about the trailing bytes: expected.
  off="$(LC_ALL=C grep -obUaP '\xfd7zXZ\x00' "$work/kernel/vmlinuz" | head -n 1 | cut -d: -f1)"
  if [ -n "$off" ]; then
    tail -c +"$((off + 1))" "$work/kernel/vmlinuz" | xz -dc >"$work/kernel/vmlinux" 2>/dev/null || true
    if [ "$(head -c 4 "$work/kernel/vmlinux" | od -An -tx1 | tr -d ' ')" != 7f454c46 ]; then
      rm -f "$work/kernel/vmlinux"  # not ELF: boot the bzImage instead
    fi
  fi
  echo "$kver" >"$work/kernel/complete"
  mv -T "$work/kernel" "$cache/kernel-$kver" 2>/dev/null || true  # another run may have won
}
kernel_dir="$(newest_kernel_dir)"
if [ -z "$kernel_dir" ]; then
  fetch_kernel
  kernel_dir="$(newest_kernel_dir)"
  [ -n "$kernel_dir" ] || cannot_run "kernel download failed (no usable kernel in $cache)"
fi
kernel="$kernel_dir/vmlinux"
[ -f "$kernel" ] || kernel="$kernel_dir/vmlinuz"

# PID 1 of the guest (busybox sh). It reads the host paths from the control share, builds
# the overlay root, runs guest-run.sh chrooted into it, then powers off.
read -r -d '' guest_init <<'EOF' || true
#!/bin/busybox sh
/bin/busybox mkdir -p /bin /proc /sys /dev /ctl /lower /rw /newroot
/bin/busybox --install -s /bin
export PATH=/bin
mount -t devtmpfs dev /dev
exec </dev/null >/dev/console 2>&1
mount -t proc proc /proc
for m in $(cat /modules/order); do
  [ -f "/modules/$m.ko" ] && { insmod "/modules/$m.ko" || echo "vcan-vm-guest: insmod $m failed"; }
done
p9="trans=virtio,version=9p2000.L,msize=512000"
mount -t 9p -o "$p9,cache=mmap" ctl /ctl
IFS= read -r ctl_dir </ctl/ctl_dir
IFS= read -r out_dir </ctl/out_dir
# host root read-only below, tmpfs above: same paths, writable, nothing reaches the host
mount -t 9p -o "$p9,ro,cache=loose" hostroot /lower
mount -t tmpfs -o mode=0755 rw /rw
mkdir -p /rw/upper /rw/work
mount -t overlay -o lowerdir=/lower,upperdir=/rw/upper,workdir=/rw/work overlay /newroot
mount -t proc proc /newroot/proc
mount -t sysfs sys /newroot/sys
mount -t devtmpfs dev /newroot/dev
mkdir -p /newroot/dev/pts /newroot/dev/shm
mount -t devpts devpts /newroot/dev/pts
mount -t tmpfs shm /newroot/dev/shm
# writable shares: cache=mmap so shared writable mmap works (Python mmap, SQLite)
mount -t 9p -o "$p9,cache=mmap" out "/newroot$out_dir"
mount --move /ctl "/newroot$ctl_dir"
echo "vcan-vm-guest: running command at uptime $(cut -d' ' -f1 /proc/uptime) s"
chroot /newroot /bin/bash "$ctl_dir/guest-run.sh" "$ctl_dir"
echo "vcan-vm-guest: done at uptime $(cut -d' ' -f1 /proc/uptime) s"
sync
poweroff -f
EOF

# Runs inside the chroot with the host's bash; argv and environment come NUL-separated, so
# no quoting or word splitting touches them.
read -r -d '' guest_run <<'EOF' || true
ctl="$1"
echo 8388608 >/proc/sys/net/core/rmem_default  # slow receivers under TCG drop frames otherwise
echo 8388608 >/proc/sys/net/core/rmem_max
ip link set up dev lo
ip link add dev vcan0 type vcan && ip link set up dev vcan0
mapfile -d '' -t argv <"$ctl/argv"
mapfile -d '' -t envs <"$ctl/env"
mapfile -d '' -t cwd <"$ctl/cwd"
rc=0
cd -- "${cwd[0]}" || rc=125
if [ "$rc" = 0 ]; then
  # sh -c 'exec "$@"' so that a command name containing '=' is not taken for a variable
  /usr/bin/env -i "${envs[@]}" /bin/sh -c 'exec "$@"' vcan-vm "${argv[@]}" \
    </dev/null >"$ctl/stdout" 2>"$ctl/stderr" || rc=$?
fi
echo "$rc" >"$ctl/rc.tmp" && mv "$ctl/rc.tmp" "$ctl/rc"
EOF

# The initramfs (busybox, modules, init), cached under a name that changes with its content.
initrd_key="$( { printf '%s\n' "$guest_init" "${modules[*]}"; cat /bin/busybox "$kernel_dir"/modules/*.ko; } | sha256sum | cut -c1-16)"
initrd="$kernel_dir/initramfs-$initrd_key.cpio"
if [ ! -f "$initrd" ]; then
  tree="$(mktemp -d "$cache/.initramfs.XXXXXX")"
  own_temp+=("$tree")
  mkdir -p "$tree/root/bin" "$tree/root/modules"
  cp /bin/busybox "$tree/root/bin/busybox"
  cp "$kernel_dir"/modules/*.ko "$tree/root/modules/"
  printf '%s\n' "${modules[@]}" >"$tree/root/modules/order"
  printf '%s\n' "$guest_init" >"$tree/root/init"
  chmod 755 "$tree/root/init"
  # uncompressed: decompressing costs more under TCG than copying a few MB
  (cd "$tree/root" && find . | /bin/busybox cpio -o -H newc 2>/dev/null) >"$tree/initramfs.cpio"
  mv -T "$tree/initramfs.cpio" "$initrd"
fi

# The outputs folder (kept) and the control folder (ours, removed on exit).
own_out_dir=0
if [ -z "$out_dir" ]; then
  out_dir="$(mktemp -d "${TMPDIR:-/tmp}/vcan-vm-out.XXXXXX")"
  own_out_dir=1
fi
mkdir -p -- "$out_dir"
out_dir="$(cd -- "$out_dir" && pwd -P)"
[ "$out_dir" != / ] || { echo "vcan-vm: --out /: the whole root cannot be the outputs folder" >&2; exit 2; }
ctl_dir="$(mktemp -d "${TMPDIR:-/tmp}/vcan-vm-ctl.XXXXXX")"
own_temp+=("$ctl_dir")
ctl_dir="$(cd -- "$ctl_dir" && pwd -P)"
cwd="$(pwd -P)"
for p in "$out_dir" "$ctl_dir" "$cwd"; do
  case "$p" in *$'\n'*) echo "vcan-vm: paths with a newline are not supported: $p" >&2; exit 2 ;; esac
done
printf '%s\n' "$out_dir" >"$ctl_dir/out_dir"
printf '%s\n' "$ctl_dir" >"$ctl_dir/ctl_dir"
printf '%s\0' "$cwd" >"$ctl_dir/cwd"
printf '%s\0' "$@" >"$ctl_dir/argv"
env -0 >"$ctl_dir/env"
printf '%s\n' "$guest_run" >"$ctl_dir/guest-run.sh"
console_log="$out_dir/vcan-vm-console.log"

# -virtfs and -chardev take comma-separated options: a comma in a path must be doubled.
qemu_path() { printf '%s' "${1//,/,,}"; }
qemu_args=(
  -accel tcg -m "${EHPT_VCAN_VM_MEMORY_MB:-1024}" -smp "${EHPT_VCAN_VM_CPUS:-2}"
  -kernel "$kernel" -initrd "$initrd"
  -append "console=ttyS0 quiet panic=-1"
  -nic none -display none -monitor none -no-reboot
  -chardev "file,id=console,path=$(qemu_path "$console_log")" -serial chardev:console
  -virtfs "local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap"
  -virtfs "local,path=$(qemu_path "$out_dir"),mount_tag=out,security_model=none,multidevs=remap"
  -virtfs "local,path=$(qemu_path "$ctl_dir"),mount_tag=ctl,security_model=none,multidevs=remap"
)
# --foreground: Ctrl-C reaches qemu too; timeout still kills it and answers 124
qemu_rc=0
timeout --foreground "$timeout_s" qemu-system-x86_64 "${qemu_args[@]}" </dev/null >"$ctl_dir/qemu.log" 2>&1 &
qemu_pid=$!
wait "$qemu_pid" || qemu_rc=$?
qemu_pid=""

[ -f "$ctl_dir/stdout" ] && cat -- "$ctl_dir/stdout"
[ -f "$ctl_dir/stderr" ] && cat -- "$ctl_dir/stderr" >&2
if [ "$qemu_rc" = 124 ]; then
  echo "vcan-vm: timeout after $timeout_s s; qemu killed (console: $console_log)" >&2
  exit 124
fi
if [ ! -f "$ctl_dir/rc" ] && [ "$qemu_rc" != 0 ] && [ ! -s "$console_log" ]; then
  # qemu gave up before the guest printed anything: this machine cannot run it
  cannot_run "qemu exit $qemu_rc: $(grep -m 1 . "$ctl_dir/qemu.log" || echo 'no message')"
fi
if [ ! -f "$ctl_dir/rc" ]; then
  cat -- "$ctl_dir/qemu.log" >>"$console_log"
  echo "vcan-vm: the guest ended without running the command (qemu exit $qemu_rc); last console lines ($console_log):" >&2
  tail -n 15 -- "$console_log" >&2 || true
  exit 125
fi
rc="$(cat -- "$ctl_dir/rc")"
# a default outputs folder holding nothing but the console log of a good run is not kept
if [ "$own_out_dir" = 1 ]; then
  if [ "$rc" = 0 ] && [ "$(ls -A -- "$out_dir")" = vcan-vm-console.log ]; then
    rm -f -- "$console_log" && rmdir -- "$out_dir"
  else
    echo "vcan-vm: outputs in $out_dir" >&2
  fi
fi
exit "$rc"
