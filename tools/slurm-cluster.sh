#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Starts and stops a throw-away one-node Slurm cluster (munged + slurmctld + slurmd) living
# entirely in one folder, for end-to-end tests of `ehpt sweep --executor slurm`.
#
# usage: tools/slurm-cluster.sh start DIR   (DIR exists and is empty)
#        tools/slurm-cluster.sh stop DIR
#
# start: installs slurm-wlm and munge on first use (Debian), starts the three daemons as the
# current user (root: SlurmUser=root) on private ports, waits until the node is idle (60 s),
# and prints one line, DIR/env.sh: sourcing it exports SLURM_CONF, which is all sbatch, squeue,
# sinfo, scancel and scontrol need (the munge socket is named in slurm.conf, AuthInfo). The
# partition is `debug` (the default). Exit 77 with one line on stderr: the cluster cannot run
# here (install failed, a daemon died, the node never became idle); whatever was started is
# stopped again and the logs stay in DIR/log.
# stop: cancels the cluster's jobs, then stops the daemons named by DIR/pid/* (TERM, 10 s,
# KILL) and checks they are gone. Idempotent. Never signals a process by name.
#
# Nothing outside DIR is written (no /etc, no systemd), except the package install.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
daemons=(munged slurmctld slurmd)  # start order; stop goes the other way

usage() {
  echo "usage: tools/slurm-cluster.sh start|stop DIR" >&2
  exit 2
}
[ $# -eq 2 ] || usage
cmd="$1"
[ -d "$2" ] || { echo "slurm-cluster: $2: no such folder" >&2; exit 2; }
dir="$(cd -- "$2" && pwd -P)"
# slurm.conf cannot quote paths (and AuthInfo splits at ','), and unix socket paths (munge's,
# slurmd's per-step sockets in the spool) must stay under 108 bytes: keep DIR plain and short.
if [[ ! "$dir" =~ ^[A-Za-z0-9_./+-]+$ ]] || [ ${#dir} -gt 60 ]; then
  echo "slurm-cluster: $dir: use a short path of letters, digits and ._+-/ (e.g. mktemp -d)" >&2
  exit 2
fi
conf="$dir/slurm.conf"

# True while PID runs and is one of ours: its command line names DIR (so a recycled pid of
# some other process is never signalled). A zombie (our own dead child) counts as gone.
ours_alive() {
  local pid="$1" state
  [[ "$pid" =~ ^[0-9]+$ ]] || return 1
  state="$(sed -n 's/.*) \([A-Z]\) .*/\1/p' "/proc/$pid/stat" 2>/dev/null)" || return 1
  [ -n "$state" ] && [ "$state" != Z ] || return 1
  tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null | grep -qF -- "$dir/"
}

# Ends the daemon whose pid file is DIR/pid/NAME: TERM, up to GRACE tenths of a second
# (default 100), then KILL. 1: survived.
stop_one() {
  local name="$1" grace="${2:-100}" pid i
  pid="$(cat -- "$dir/pid/$name" 2>/dev/null)" || return 0
  if ours_alive "$pid"; then
    kill -TERM "$pid" 2>/dev/null || true
    for ((i = 0; i < grace; i++)); do ours_alive "$pid" || break; sleep 0.1; done
    if ours_alive "$pid"; then
      kill -KILL "$pid" 2>/dev/null || true
      for ((i = 0; i < 20; i++)); do ours_alive "$pid" || break; sleep 0.1; done
    fi
    if ours_alive "$pid"; then
      echo "slurm-cluster: $name (pid $pid) survived SIGKILL" >&2
      return 1
    fi
  fi
  rm -f -- "$dir/pid/$name"
}

stop_all() {
  local grace="${1:-100}" rc=0 i name
  # Jobs first, while slurmctld still runs: slurmstepd and the job's processes are not
  # children of slurmd's pid and would outlive it. KillWait=2 bounds how long this takes.
  if [ -f "$conf" ] && ours_alive "$(cat -- "$dir/pid/slurmctld" 2>/dev/null)"; then
    if SLURM_CONF="$conf" timeout 5 scancel --quiet --partition=debug >/dev/null 2>&1; then
      for ((i = 0; i < 50; i++)); do
        # finished jobs stay known for MinJobAge: only those not yet over count
        [ -z "$(SLURM_CONF="$conf" timeout 5 squeue -h -t PD,CF,R,CG,S -o %i 2>/dev/null)" ] && break
        sleep 0.2
      done
    fi
  fi
  for ((i = ${#daemons[@]} - 1; i >= 0; i--)); do
    name="${daemons[i]}"
    stop_one "$name" "$grace" || rc=1
  done
  return "$rc"
}

if [ "$cmd" = stop ]; then
  stop_all
  exit
fi
[ "$cmd" = start ] || usage

[ -z "$(ls -A -- "$dir")" ] || { echo "slurm-cluster: $dir is not empty" >&2; exit 2; }
cannot_run() {
  echo "slurm-cluster: cannot run a Slurm cluster here: $*" >&2
  # short grace: a slurmd that cannot reach slurmctld ignores TERM for ~10 s
  stop_all 20 >/dev/null 2>&1 || true
  exit 77
}
# apt output goes to stderr: stdout carries only the env file's path
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null \
   || ! command -v sbatch >/dev/null; then
  "$here/apt_install.sh" slurm-cluster slurm-wlm munge >&2 || cannot_run "apt install slurm-wlm munge failed"
fi
for p in munged slurmctld slurmd sbatch sinfo; do command -v "$p" >/dev/null || cannot_run "no $p"; done

mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/log" "$dir/pid" "$dir/run"
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$dir/munge/munge.key"

# Two free TCP ports: random in 20000-59999, not listening now. Read from /proc (state 0A is
# LISTEN) so that neither iproute2 nor gawk is needed.
listening=" "
while read -r _ local_addr _ state _; do
  [ "$state" = 0A ] && listening+="$((16#${local_addr##*:})) "
done < <(cat /proc/net/tcp /proc/net/tcp6 2>/dev/null || true)
ports=()
for ((i = 0; ${#ports[@]} < 2; i++)); do
  [ "$i" -lt 200 ] || cannot_run "no free TCP port found"
  p=$((20000 + (RANDOM * 32768 + RANDOM) % 40000))
  [[ "$listening" == *" $p "* ]] || { ports+=("$p"); listening+="$p "; }
done
node="$(hostname -s 2>/dev/null || uname -n)"
node="${node%%.*}"

# NodeAddr/SlurmctldHost addresses are 127.0.0.1 so nothing depends on name resolution.
# SelectTypeParameters=CR_Core: memory is not a consumable, so array tasks share the node
# instead of each asking for all of it. batch_sched_delay=0: start array tasks on the next
# scheduler pass (1 s) instead of every 3 s. PlugStackConfig: an empty file of ours, not /etc's.
: >"$dir/plugstack.conf"
cat >"$conf" <<EOF
ClusterName=ehpt
SlurmctldHost=$node(127.0.0.1)
SlurmUser=$(id -un)
SlurmctldPort=${ports[0]}
SlurmdPort=${ports[1]}
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
SchedulerParameters=batch_sched_delay=0
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MinJobAge=300
KillWait=2
MailProg=/bin/true
PlugStackConfig=$dir/plugstack.conf
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
NodeName=$node NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
printf 'export SLURM_CONF=%q\n' "$conf" >"$dir/env.sh"

# Each daemon runs in the foreground under setsid (own session: no terminal, no signals from
# the caller's process group), so $! is its pid from the first moment and no daemonizing
# race exists; its stdio goes to DIR/log so a caller reading our stdout does not wait on it.
start_one() {
  local name="$1"
  shift
  SLURM_CONF="$conf" setsid "$@" </dev/null >>"$dir/log/$name.out" 2>&1 &
  echo "$!" >"$dir/pid/$name"
}
last_log_line() {
  local f
  f="$( (ls -t -- "$dir/log/$1".* 2>/dev/null || true) | head -n 1)"
  [ -n "$f" ] && grep -v '^\s*$' -- "$f" | tail -n 1
}
died() { cannot_run "$1 exited at start: $(last_log_line "$1" || echo 'no log') (logs: $dir/log)"; }

# --force: munged wants every folder above its socket enterable by all, and DIR (mktemp -d)
# is 0700; that only matters to other users, and only this user talks to this cluster.
start_one munged munged -F --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
  --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munged.seed"
for ((i = 0; i < 100; i++)); do
  [ -S "$dir/munge/munge.socket" ] && break
  ours_alive "$(cat "$dir/pid/munged")" || died munged
  sleep 0.1
done
[ -S "$dir/munge/munge.socket" ] || cannot_run "munged made no socket in 10 s (logs: $dir/log)"
start_one slurmctld slurmctld -D -f "$conf"
start_one slurmd slurmd -D -f "$conf" -N "$node"

# Wait for the node to register and turn idle.
deadline=$((SECONDS + 60))
while :; do
  for name in "${daemons[@]}"; do ours_alive "$(cat "$dir/pid/$name")" || died "$name"; done
  # (sinfo retries a controller that does not answer yet; timeout keeps each try short)
  [ "$(SLURM_CONF="$conf" timeout 3 sinfo -h -n "$node" -o %T 2>/dev/null || true)" = idle ] && break
  [ "$SECONDS" -lt "$deadline" ] || cannot_run "node $node not idle after 60 s (logs: $dir/log)"
  sleep 0.5
done
echo "$dir/env.sh"
