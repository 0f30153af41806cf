#!/usr/bin/env bash
# A throw-away single-node Slurm cluster on this machine, for trying dfo_sweep --slurm and for its
# test: munged with its own key and socket, slurmctld and slurmd with a slurm.conf generated for
# this host (its CPUs and memory from `slurmd -C`, free ports, proctrack/linuxproc, no cgroups),
# everything under DIR. Nothing of the system's own munge or Slurm set-up is used or touched.
#
#   tools/local_slurm.sh check       # can a local Slurm run here (root, programs installed)?
#   tools/local_slurm.sh start DIR   # last line: SLURM_CONF=DIR/slurm.conf (export it for sbatch)
#   tools/local_slurm.sh stop DIR    # stops the three daemons started for DIR
#
# Needs root (slurmd runs jobs as their user) and the Debian packages slurm-wlm and munge.
# Exit status of check and start: 0 can run / running; 3 cannot run here (not root, or a program
# of slurm-wlm or munge missing: which, on the last line). Of start: 4 Slurm and munge are
# installed and this is root, but the cluster did not come up (a folder or the munge key cannot
# be made, a daemon does not start, the node does not become idle): the daemons' log tails, then
# the reason on the last line. 2 usage.
set -u

usage() { echo "usage: $0 check | start DIR | stop DIR" >&2; exit 2; }
cmd=${1:-}
case "$cmd" in
  check) [ $# -eq 1 ] || usage ;;
  start|stop) [ $# -eq 2 ] || usage ;;
  *) usage ;;
esac
dir=${2:-}

stop() {
  if [ -f "$dir/slurm.conf" ] && command -v scontrol >/dev/null 2>&1; then
    SLURM_CONF="$dir/slurm.conf" timeout 10 scontrol shutdown >/dev/null 2>&1 || true
  fi
  for name in slurmd slurmctld munged; do
    pid_file="$dir/run/$name.pid"
    [ -f "$pid_file" ] || continue
    pid=$(cat "$pid_file" 2>/dev/null)
    [ -n "$pid" ] || continue
    # The Slurm daemons got "scontrol shutdown"; munged (and a daemon that does not listen) TERM.
    for i in $(seq 1 50); do
      kill -0 "$pid" 2>/dev/null || break
      if [ "$name" = munged ] || [ "$i" -eq 20 ]; then kill "$pid" 2>/dev/null; fi
      sleep 0.1
    done
    kill -0 "$pid" 2>/dev/null && kill -9 "$pid" 2>/dev/null
    rm -f "$pid_file"
  done
  return 0
}

cannot() { echo "local_slurm: cannot run a local Slurm here: $*"; exit 3; }

# Only these two make a local Slurm impossible here; anything that fails after them is a failure.
check() {
  [ "$(id -u)" -eq 0 ] || cannot "not root (slurmd must run as root to start jobs)"
  local missing=""
  for p in munged mungekey slurmctld slurmd sbatch squeue sinfo scontrol; do
    command -v "$p" >/dev/null 2>&1 || missing="$missing $p"
  done
  [ -z "$missing" ] ||
    cannot "slurm-wlm or munge not installed:$missing not found (Debian: apt-get install" \
      "slurm-wlm munge)"
}

# Slurm and munge are installed and this is root, yet the cluster does not come up.
failed() {
  for f in "$dir"/log/*.log "$dir"/log/*.stdout; do
    [ -s "$f" ] || continue
    echo "== $f"
    tail -n 8 "$f"
  done
  echo "local_slurm: the local cluster did not start: $*"
  stop
  exit 4
}

start() {
  check
  mkdir -p "$dir"/{munge,state,spool,log,run} || failed "cannot create $dir"
  dir=$(cd "$dir" && pwd)
  chmod 755 "$dir"
  chmod 700 "$dir/munge"
  rm -f "$dir/munge/munge.key"
  mungekey --create --keyfile="$dir/munge/munge.key" >/dev/null 2>&1 ||
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none ||
    failed "cannot create a munge key"
  chmod 600 "$dir/munge/munge.key"
  munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munge/munged.seed" </dev/null >"$dir/log/munged.stdout" 2>&1 ||
    failed "munged does not start"

  host=$(hostname -s)
  read -r cpus mem < <(slurmd -C 2>/dev/null |
    sed -n 's/.*CPUs=\([0-9]*\).*RealMemory=\([0-9]*\).*/\1 \2/p' | head -1)
  [ -n "${cpus:-}" ] || cpus=$(nproc)
  [ -n "${mem:-}" ] || mem=$(awk '/MemTotal/ {print int($2 / 1024)}' /proc/meminfo)
  free_port() {
    local p
    for i in $(seq 1 100); do
      p=$((20000 + RANDOM % 40000))
      if ! command -v ss >/dev/null 2>&1 || [ -z "$(ss -Hltn "sport = :$p" 2>/dev/null)" ]; then
        echo $p
        return
      fi
    done
    echo $p
  }
  ctld_port=$(free_port)
  slurmd_port=$(free_port)
  [ "$ctld_port" != "$slurmd_port" ] || slurmd_port=$((ctld_port + 1))

  cat >"$dir/slurm.conf" <<EOF
# Written by tools/local_slurm.sh: a single-node cluster on $host for tests.
ClusterName=dfolocal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
MpiDefault=none
SwitchType=switch/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
ReturnToService=2
MinJobAge=60
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=dfo Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF

  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -f "$SLURM_CONF" -i </dev/null >"$dir/log/slurmctld.stdout" 2>&1 ||
    failed "slurmctld does not start"
  slurmd -f "$SLURM_CONF" -N "$host" </dev/null >"$dir/log/slurmd.stdout" 2>&1 ||
    failed "slurmd does not start"
  for i in $(seq 1 60); do
    state=$(sinfo -h -N -o %t 2>/dev/null | head -1)
    case "$state" in
      idle*|mix*|alloc*) echo "SLURM_CONF=$SLURM_CONF"; exit 0 ;;
    esac
    sleep 0.5
  done
  failed "the node did not become idle in 30 s (state '${state:-none}')"
}

case "$cmd" in
  check) check && echo "local_slurm: root, and slurm-wlm and munge are installed" ;;
  start) start ;;
  stop) stop ;;
esac
