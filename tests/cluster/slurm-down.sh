#!/usr/bin/env bash
# Stops the cluster tests/cluster/slurm-up.sh started under DIR: slurmd, slurmctld and munged,
# each by the pid in its pid file (nothing else is touched), then waits for them to go.
#   tests/cluster/slurm-down.sh DIR
set -uo pipefail
dir=${1:?usage: slurm-down.sh DIR}
pids=()
for file in slurmd.pid slurmctld.pid munge/munged.pid; do
    [ -s "$dir/$file" ] || continue
    pid=$(cat "$dir/$file")
    kill "$pid" 2>/dev/null && pids+=("$pid")
done
for pid in "${pids[@]}"; do
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
done
exit 0
