#!/usr/bin/env bash
# A single-node Slurm cluster on the local machine, for tests (tests/external/farm_slurm.rs) and for trying
# `brume farm slurm` by hand. Debian 12's slurm-wlm 22.05 and munge, daemons started directly
# (no systemd), everything under one folder, on 127.0.0.1.
#
#   tools/slurm/cluster.sh install        apt-get the packages if any is missing
#   tools/slurm/cluster.sh start          start munged, slurmctld, slurmd; wait for an idle node
#   tools/slurm/cluster.sh stop           stop them by the PIDs start recorded
#   tools/slurm/cluster.sh run CMD...     start, run CMD with SLURM_CONF set, stop (trap)
#
# Environment: BRUME_SLURM_DIR (state, spool, logs, munge socket; default /tmp/brume-slurm),
# BRUME_SLURM_CTLD_PORT / BRUME_SLURMD_PORT (default 6817 / 6818; set both to run two
# clusters side by side). After `start`, every Slurm command needs
#   export SLURM_CONF=$BRUME_SLURM_DIR/slurm.conf
# which `start` prints as its last line.
#
# Slurm set-up traps it encodes (see docs/farm.md):
# - kill_invalid_depend belongs in DependencyParameters; under SchedulerParameters it is
#   silently ignored and a job behind a failed afterok dependency waits forever.
# - munged checks that every folder above its socket is world-executable: the folder is 0755.
# - No cgroups here: a task sees every core; Brume sizes its pool from SLURM_CPUS_PER_TASK.
# - sacct needs slurmdbd (not run here): job states come from `scontrol -o show job`, which
#   forgets finished jobs after MinJobAge (set to an hour below).
set -euo pipefail

DIR="${BRUME_SLURM_DIR:-/tmp/brume-slurm}"
CTLD_PORT="${BRUME_SLURM_CTLD_PORT:-6817}"
SLURMD_PORT="${BRUME_SLURMD_PORT:-6818}"
PACKAGES=(slurmctld slurmd slurm-client munge)

say() { echo "slurm-cluster: $*" >&2; }

install() {
    local missing=()
    for b in slurmctld slurmd sbatch munged; do
        command -v "$b" >/dev/null 2>&1 || [ -x "/usr/sbin/$b" ] || missing+=("$b")
    done
    if [ ${#missing[@]} -eq 0 ]; then
        return 0
    fi
    say "installing ${PACKAGES[*]} (missing: ${missing[*]})"
    export DEBIAN_FRONTEND=noninteractive
    if ! apt-get install -y --no-install-recommends "${PACKAGES[@]}" >"$DIR.install.log" 2>&1; then
        apt-get update >>"$DIR.install.log" 2>&1 || true
        apt-get install -y --no-install-recommends "${PACKAGES[@]}" >>"$DIR.install.log" 2>&1 || {
            say "apt-get install failed; see $DIR.install.log"
            tail -5 "$DIR.install.log" >&2
            return 1
        }
    fi
}

stop() {
    local pids="$DIR/pids"
    [ -f "$pids" ] || return 0
    # Reverse start order: slurmd, slurmctld, munged.
    tac "$pids" | while read -r name pid; do
        if kill -0 "$pid" 2>/dev/null; then
            kill -TERM "$pid" 2>/dev/null || true
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            kill -0 "$pid" 2>/dev/null && kill -KILL "$pid" 2>/dev/null || true
            say "stopped $name ($pid)"
        fi
    done
    rm -f "$pids"
}

# Runs a daemon in the background and records its PID.
spawn() {
    local name="$1"
    shift
    "$@" >"$DIR/$name.out" 2>&1 &
    echo "$name $!" >>"$DIR/pids"
}

fail_start() {
    say "$1"
    for f in "$DIR"/*.log "$DIR"/*.out; do
        [ -f "$f" ] && { echo "--- $f" >&2; tail -15 "$f" >&2; }
    done
    stop
    exit 1
}

start() {
    install
    stop
    mkdir -p "$DIR"
    # munged refuses a socket whose folders are not world-executable (mktemp -d gives 0700).
    chmod 0755 "$DIR"
    mkdir -p "$DIR/munge" "$DIR/state" "$DIR/spool"
    chmod 0755 "$DIR/munge"
    : >"$DIR/pids"
    # The munge key: made here, readable by root only (munged insists).
    if [ ! -s "$DIR/munge/munge.key" ]; then
        dd if=/dev/urandom of="$DIR/munge/munge.key" bs=1024 count=1 status=none
    fi
    chmod 0400 "$DIR/munge/munge.key"
    local sock="$DIR/munge/munge.socket.2"
    spawn munged munged --foreground --force --key-file="$DIR/munge/munge.key" \
        --socket="$sock" --pid-file="$DIR/munge/munged.pid" \
        --log-file="$DIR/munged.log" --seed-file="$DIR/munge/munged.seed"
    for _ in $(seq 100); do [ -S "$sock" ] && break; sleep 0.1; done
    [ -S "$sock" ] || fail_start "munged did not open $sock"

    local host node
    host="$(hostname -s)"
    # The node as slurmd sees it (CPUs, sockets, cores, memory), on 127.0.0.1.
    node="$(slurmd -C | head -1)"
    [[ "$node" == NodeName=* ]] || fail_start "slurmd -C printed: $node"
    cat >"$DIR/slurm.conf" <<EOF
ClusterName=brume
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$sock
CredType=cred/munge
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/slurmctld.log
SlurmdLogFile=$DIR/slurmd.log
PlugStackConfig=$DIR/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
DependencyParameters=kill_invalid_depend
ReturnToService=2
MpiDefault=none
SwitchType=switch/none
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
MinJobAge=3600
KillWait=10
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
    : >"$DIR/plugstack.conf"
    export SLURM_CONF="$DIR/slurm.conf"
    spawn slurmctld slurmctld -D -i -f "$SLURM_CONF"
    spawn slurmd slurmd -D -f "$SLURM_CONF"
    local state=""
    for _ in $(seq 300); do
        state="$(sinfo -h -o %t 2>/dev/null | head -1 || true)"
        [ "$state" = "idle" ] && break
        sleep 0.1
    done
    [ "$state" = "idle" ] || fail_start "the node is not idle after 30 s (state: '${state:-none}')"
    say "node $host idle ($(sinfo -h -o '%c CPUs')), ports $CTLD_PORT/$SLURMD_PORT, folder $DIR"
    echo "export SLURM_CONF=$SLURM_CONF"
}

case "${1:-}" in
install) mkdir -p "$(dirname "$DIR")"; install ;;
start) start ;;
stop) stop ;;
run)
    shift
    trap stop EXIT
    start >/dev/null
    export SLURM_CONF="$DIR/slurm.conf"
    "$@"
    ;;
*)
    echo "usage: $0 install|start|stop|run CMD..." >&2
    exit 2
    ;;
esac
