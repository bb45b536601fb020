#!/usr/bin/env bash
# Stop the one-node SLURM started by scripts/slurm/start-local-slurm.sh: cancel its jobs, then stop
# slurmd, slurmctld and munged by their pid files. Leaves the packages and /etc/slurm/slurm.conf in place.
set -uo pipefail

stop() {  # stop the daemon whose pid file is $1, waiting up to 10 s
    local pidfile=$1 pid
    [[ -f "$pidfile" ]] || return 0
    pid=$(cat "$pidfile")
    kill "$pid" 2>/dev/null || return 0
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.2; done
    echo "stop-local-slurm: $pidfile ($pid) still running" >&2
}

command -v scancel >/dev/null && scancel --full --quiet --partition=debug 2>/dev/null
stop /run/slurmd.pid
stop /run/slurmctld.pid
stop /run/munge/munged.pid
echo "stop-local-slurm: stopped" >&2
