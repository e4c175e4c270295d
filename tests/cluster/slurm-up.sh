#!/usr/bin/env bash
# Starts a one-node Slurm cluster for the tests, everything under DIR:
#   tests/cluster/slurm-up.sh DIR [OWNER_PID]
# DIR gets a generated munge key, munged's socket, slurm.conf (one node: this host with its real
# CPU count and memory, as `slurmd -C` reports them), the daemons' state, spool, logs and pid
# files. The daemons are munged, slurmctld and slurmd, on free ports, so a system cluster (or a
# second test run) is left alone. When the node is idle, the last line printed is
#   SLURM_CONF=DIR/slurm.conf
# which clients (sbatch, sinfo, squeue, scancel) need in their environment.
# With OWNER_PID, a watchdog tears the cluster down (tests/cluster/slurm-down.sh DIR) as soon as
# that process ends, however it ends: a test binary that starts the cluster never leaves daemons
# behind. Needs root (slurmd runs jobs as their submitting user) and Debian's slurm-wlm and munge.
set -euo pipefail

dir=${1:?usage: slurm-up.sh DIR [OWNER_PID]}
owner=${2:-}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)

fail() {
    echo "slurm-up: $*" >&2
    for log in munged.log slurmctld.log slurmd.log; do
        [ -s "$dir/$log" ] && { echo "--- $log (last lines)" >&2; tail -n 15 "$dir/$log" >&2; }
    done
    "$here/slurm-down.sh" "$dir" >/dev/null 2>&1 || true
    exit 1
}

[ "$(id -u)" = 0 ] || fail "must run as root"
for tool in munged slurmctld slurmd sinfo sbatch; do
    command -v "$tool" >/dev/null || fail "$tool not found (apt-get install slurm-wlm munge)"
done

# Two free TCP ports on loopback for slurmctld and slurmd.
read -r ctld_port slurmd_port < <(python3 -c '
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in socks))
')

mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
chmod 700 "$dir/munge"
# munged insists on a key only its user can read, in a folder nobody else can write.
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1 count=1024 status=none
chmod 400 "$dir/munge/munge.key"
socket="$dir/munge/munge.socket"
munged --key-file="$dir/munge/munge.key" --socket="$socket" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/munged.log" \
    --seed-file="$dir/munge/munged.seed" --force \
    || fail "munged did not start"
for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || fail "munged made no socket at $socket"

host=$(hostname -s)
# CPUs, sockets, cores, threads and RealMemory of this machine, as slurmd sees them.
node=$(slurmd -C | head -n 1 | sed -e "s/^NodeName=[^ ]*/NodeName=$host/")
cat >"$dir/slurm.conf" <<EOF
ClusterName=hdrvis-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
MinJobAge=300
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF

export SLURM_CONF="$dir/slurm.conf"
# -i: start afresh, ignoring any saved state.
slurmctld -i -f "$SLURM_CONF" >>"$dir/slurmctld.log" 2>&1 || fail "slurmctld did not start"
slurmd -f "$SLURM_CONF" -N "$host" >>"$dir/slurmd.log" 2>&1 || fail "slurmd did not start"

if [ -n "$owner" ]; then
    # Detached from the caller's output, so a caller reading this script's output sees EOF.
    setsid bash -c '
        while kill -0 "$1" 2>/dev/null; do sleep 1; done
        "$2/slurm-down.sh" "$3"
        rm -rf "$3"' watchdog "$owner" "$here" "$dir" </dev/null >/dev/null 2>&1 &
    echo $! >"$dir/watchdog.pid"
fi

for _ in $(seq 120); do
    state=$(sinfo -h -N -o '%t' 2>/dev/null | head -n 1 || true)
    [ "$state" = idle ] && break
    sleep 0.25
done
[ "$state" = idle ] || fail "node not idle after 30 s (sinfo says '${state:-nothing}')"
echo "SLURM_CONF=$SLURM_CONF"
