#!/usr/bin/env bash
# Install, configure and start a one-node SLURM cluster on 127.0.0.1 (Debian/Ubuntu, as root).
#
# Used by CI (.ci/run) and the SLURM tests (tests/optimizer/campaign/test_slurm.py), and by developers who
# want to try millfoil's `slurm` execution backend without a real cluster:
#
#     sudo scripts/slurm/start-local-slurm.sh      # idempotent: returns at once if the node is up
#     sinfo                                         # one node, "localhost", idle
#     sudo scripts/slurm/stop-local-slurm.sh
#
# The node is this machine: NodeName=localhost at 127.0.0.1 with every core (nproc) and 90 % of the
# memory (free). Containers lack cgroups, so processes are tracked by /proc (proctrack/linuxproc) and tasks
# are not confined (task/none). Daemons log to /var/log/slurm/ and keep state in /var/lib/slurm/.
# Exit status: 0 when `sinfo` shows the node idle (or busy), non-zero with the reason on stderr otherwise.
set -euo pipefail

CONF_DIR=/etc/slurm
CONF="$CONF_DIR/slurm.conf"
LOG_DIR=/var/log/slurm
STATE_DIR=/var/lib/slurm
NODE=localhost
WAIT_S=${SLURM_START_WAIT_S:-60}

say() { echo "start-local-slurm: $*" >&2; }
fail() { say "$*"; exit 1; }

node_state() { sinfo -h -N -n "$NODE" -o %t 2>/dev/null | head -n1 || true; }
is_up() { [[ "$1" =~ ^(idle|mix|mixed|alloc|allocated|comp|completing)$ ]]; }

[[ $(id -u) -eq 0 ]] || fail "run as root (it installs packages and starts system daemons)"

if command -v sinfo >/dev/null && state=$(node_state) && is_up "$state"; then
    say "already running: node $NODE is $state"
    exit 0
fi

install_packages() {
    local missing=()
    for cmd in slurmctld slurmd munged sinfo; do command -v "$cmd" >/dev/null || missing+=("$cmd"); done
    [[ ${#missing[@]} -eq 0 ]] && return
    say "installing slurmctld slurmd munge (missing: ${missing[*]})"
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -q --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null \
        || { apt-get update -q >/dev/null && apt-get install -y -q --no-install-recommends \
                 slurmctld slurmd slurm-client munge >/dev/null; } \
        || fail "apt-get could not install slurmctld slurmd slurm-client munge"
}

write_config() {
    local cpus mem_mb
    cpus=$(nproc)
    mem_mb=$(free -m | awk '/^Mem:/ {printf "%d", $2 * 0.9}')
    mkdir -p "$CONF_DIR" "$LOG_DIR" "$STATE_DIR/slurmctld" "$STATE_DIR/slurmd"
    cat >"$CONF" <<CONF
# One-node SLURM on 127.0.0.1, written by scripts/slurm/start-local-slurm.sh (millfoil). Not for production.
ClusterName=millfoil-local
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
# containers have no usable cgroups: track processes through /proc, do not confine tasks
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=$LOG_DIR/slurmctld.log
SlurmdLogFile=$LOG_DIR/slurmd.log
StateSaveLocation=$STATE_DIR/slurmctld
SlurmdSpoolDir=$STATE_DIR/slurmd
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
MinJobAge=60
NodeName=$NODE NodeAddr=127.0.0.1 NodeHostname=$NODE CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
CONF
    say "wrote $CONF (CPUs=$cpus RealMemory=${mem_mb} MB)"
}

running() { [[ -f "$1" ]] && kill -0 "$(cat "$1")" 2>/dev/null; }

start_munge() {
    if running /run/munge/munged.pid; then return; fi
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    chmod 0755 /run/munge
    [[ -f /etc/munge/munge.key ]] || { mungekey --create --keyfile=/etc/munge/munge.key; chown munge:munge /etc/munge/munge.key; }
    runuser -u munge -- /usr/sbin/munged || fail "munged did not start (see /var/log/munge/munged.log)"
    munge -n | unmunge >/dev/null || fail "munge round trip failed"
}

start_slurm() {
    running /run/slurmctld.pid || slurmctld || fail "slurmctld did not start (see $LOG_DIR/slurmctld.log)"
    running /run/slurmd.pid || slurmd -N "$NODE" || fail "slurmd did not start (see $LOG_DIR/slurmd.log)"
}

wait_for_node() {
    local t=0 state
    while (( t < WAIT_S )); do
        state=$(node_state)
        if is_up "$state"; then say "node $NODE is $state"; return 0; fi
        # a node left down or drained by an earlier run (e.g. restarted daemons) is put back in service
        if [[ "$state" =~ ^(down|drain|drng|fail) ]]; then
            scontrol update NodeName="$NODE" State=RESUME >/dev/null 2>&1 || true
        fi
        sleep 1; t=$((t + 1))
    done
    tail -n 20 "$LOG_DIR/slurmctld.log" "$LOG_DIR/slurmd.log" >&2 || true
    fail "node $NODE not idle after ${WAIT_S} s (state: '$(node_state)')"
}

install_packages
[[ -f "$CONF" ]] && grep -q "start-local-slurm.sh" "$CONF" || write_config
start_munge
start_slurm
wait_for_node
