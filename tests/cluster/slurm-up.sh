#!/usr/bin/env bash
# Start a one-node Slurm cluster on this machine, for the cluster tests.
#
#   tests/cluster/slurm-up.sh [DIR]        (DIR defaults to target/slurm in the repository)
#
# Installs Debian's slurmctld, slurmd, slurm-client and munge if they are missing, writes
# DIR/slurm.conf and a munge key, starts munged, slurmctld and slurmd in the background
# (no systemd: their pid files, sockets, state and logs all live under DIR), waits until
# the node is idle and prints one line: `slurm: up (<version>, <cpus> cpus)`.
# Clients need `SLURM_CONF=DIR/slurm.conf` (DIR/env.sh exports it).
# Stop it with tests/cluster/slurm-down.sh DIR.
#
# Needs root, or password-less sudo (exit 3 otherwise). Run twice, it leaves a running
# cluster as it is (restarting it only if its config changed). On failure it prints one
# line saying why, the tail of the daemon logs, stops what it started and exits 1.
#
# Environment: SLURM_UP_TIMEOUT (seconds to wait for the node, default 60),
# SLURM_UP_PORT (slurmctld's port, default 6817; slurmd uses the next one).
#
# Choices, each avoiding something seen in a container sandbox (gVisor) without systemd:
# - ProctrackType=proctrack/pgid, TaskPlugin=task/none, JobAcctGatherType=none and no
#   cgroup.conf: Slurm never touches cgroups.
# - AuthType=auth/munge with our own munged on a socket under DIR: Debian 12 ships
#   Slurm 22.05, which has no auth/slurm (that came with 23.11).
# - NodeName=localhost NodeAddr=127.0.0.1, slurmd -N localhost: independent of hostname.
# - Node line copied from `slurmd -C`: no "Node reconfigured socket/core boundaries" and
#   no drain for "Low RealMemory".
# - MailProg=/bin/true: else "error: Configured MailProg is invalid".
# - SchedulerParameters=batch_sched_delay=0,sched_min_interval=0: a wave of array tasks
#   starts about 1 s after the last one ends instead of about 3 s.
# - DependencyParameters=kill_invalid_depend: a job whose afterok can never be met is
#   cancelled, instead of pending for ever (no accounting needed either way).
# - MinJobAge=3600: `scontrol show job` tells a finished job's state for an hour, since
#   without accounting there is no sacct.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
dir=${1:-$repo/target/slurm}
timeout=${SLURM_UP_TIMEOUT:-60}
port=${SLURM_UP_PORT:-6817}

die() { echo "slurm: $*" >&2; exit 1; }

if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        mkdir -p "$dir"
        exec sudo -n env SLURM_UP_TIMEOUT="$timeout" SLURM_UP_PORT="$port" \
            bash "${BASH_SOURCE[0]}" "$(cd "$dir" && pwd)"
    fi
    echo "slurm: needs root or password-less sudo to install and run Slurm (running as $(id -un))" >&2
    exit 3
fi

case $timeout in '' | *[!0-9]*) die "SLURM_UP_TIMEOUT=$timeout is not a whole number of seconds" ;; esac
case $port in '' | *[!0-9]*) die "SLURM_UP_PORT=$port is not a port number" ;; esac

# --- install -------------------------------------------------------------------------
missing() {
    local cmd
    for cmd in slurmctld slurmd sbatch sinfo squeue scontrol munged mungekey munge; do
        command -v "$cmd" >/dev/null 2>&1 || return 0
    done
    return 1
}
if missing; then
    command -v apt-get >/dev/null 2>&1 || die "Slurm is not installed and there is no apt-get to install it"
    export DEBIAN_FRONTEND=noninteractive
    pkgs=(slurmctld slurmd slurm-client munge)
    apt=(apt-get -qq -o DPkg::Lock::Timeout=120)
    if ! apt-cache policy "${pkgs[@]}" 2>/dev/null | grep -q 'Candidate: [0-9]' ||
        apt-cache policy "${pkgs[@]}" 2>/dev/null | grep -q 'Candidate: (none)'; then
        "${apt[@]}" update >/dev/null 2>&1 || die "apt-get update failed"
    fi
    # The packages' maintainer scripts must not start the system's own munged, slurmctld
    # and slurmd (no systemd here, but init.d scripts): deny that for this install only.
    made_policy=
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d
        chmod 755 /usr/sbin/policy-rc.d
        made_policy=1
        trap 'rm -f /usr/sbin/policy-rc.d' EXIT
    fi
    log=$(mktemp)
    rc=0
    "${apt[@]}" install -y --no-install-recommends "${pkgs[@]}" >"$log" 2>&1 || rc=$?
    if [ "$rc" -ne 0 ]; then # stale package lists: update them and try once more
        rc=0
        { "${apt[@]}" update && "${apt[@]}" install -y --no-install-recommends "${pkgs[@]}"; } >"$log" 2>&1 || rc=$?
    fi
    if [ -n "$made_policy" ]; then
        rm -f /usr/sbin/policy-rc.d
        trap - EXIT
    fi
    if [ "$rc" -ne 0 ]; then
        tail -n 15 "$log" >&2
        rm -f "$log"
        die "apt-get install ${pkgs[*]} failed (exit $rc)"
    fi
    rm -f "$log"
    missing && die "installed ${pkgs[*]} but a Slurm or munge command is still missing"
fi

# --- config --------------------------------------------------------------------------
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
mkdir -p "$dir/state" "$dir/spool" "$dir/log" "$dir/run" "$dir/munge"
chmod 755 "$dir/run"   # munged wants its socket's folder open to all
chmod 700 "$dir/munge" # and its key's folder closed

node=$(slurmd -C 2>/dev/null | awk '/^NodeName=/ {
    out = ""
    for (i = 1; i <= NF; i++) if ($i !~ /^(NodeName|UpTime)=/) out = out " " $i
    print out; exit }')
[ -n "$node" ] || die "slurmd -C printed no node line"

conf=$dir/slurm.conf
cat >"$conf.new" <<EOF
# Written by tests/cluster/slurm-up.sh: a one-node cluster without cgroups or accounting.
ClusterName=bw4t
SlurmctldHost=localhost
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/run/munge.socket
MpiDefault=none
ProctrackType=proctrack/pgid
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerParameters=batch_sched_delay=0,sched_min_interval=0
DependencyParameters=kill_invalid_depend
ReturnToService=2
MinJobAge=3600
MailProg=/bin/true
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=localhost NodeAddr=127.0.0.1$node State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
printf 'export SLURM_CONF=%q\n' "$conf" >"$dir/env.sh"
export SLURM_CONF=$conf

# shellcheck source=tests/cluster/lib.sh
source "$here/lib.sh"
running=0
for d in munged slurmctld slurmd; do alive "$d" >/dev/null && running=$((running + 1)); done

# ": " and the last fatal (else error) line of a daemon's log, if any.
last_error() {
    local line
    line=$(grep -E 'fatal|Error' "$dir/log/$1.log" 2>/dev/null | tail -n 1) ||
        line=$(grep -E 'error' "$dir/log/$1.log" 2>/dev/null | grep -v -E 'pmix|PMIx|MPI:|state file|NOTE:' | tail -n 1) || line=
    [ -z "$line" ] || echo ": ${line#\[*\] }"
}
fail() {
    echo "slurm: $*" >&2
    local f
    for f in munged slurmctld slurmd; do
        [ -s "$dir/log/$f.log" ] || continue
        echo "--- $dir/log/$f.log (tail)" >&2
        tail -n 15 "$dir/log/$f.log" >&2
    done
    bash "$here/slurm-down.sh" "$dir" >/dev/null 2>&1 || true
    exit 1
}

if [ "$running" -eq 3 ] && cmp -s "$conf" "$conf.new"; then
    rm -f "$conf.new"
else
    if [ "$running" -gt 0 ]; then
        bash "$here/slurm-down.sh" "$dir" >/dev/null || die "could not stop the cluster already running in $dir"
    fi
    mv -f "$conf.new" "$conf"
    [ -s "$dir/munge/munge.key" ] || mungekey --create --keyfile="$dir/munge/munge.key" --bits=1024 ||
        die "mungekey could not create $dir/munge/munge.key"
    chmod 400 "$dir/munge/munge.key"
    rm -f "$dir/run/munge.socket" "$dir/run/munge.socket.lock" "$dir/run/"*.pid

    munged --key-file="$dir/munge/munge.key" --socket="$dir/run/munge.socket" \
        --pid-file="$dir/run/munged.pid" --seed-file="$dir/munge/munged.seed" \
        --log-file="$dir/log/munged.log" </dev/null >>"$dir/log/munged.log" 2>&1 ||
        fail "munged did not start"
    for _ in $(seq 50); do
        munge -n -S "$dir/run/munge.socket" 2>/dev/null | unmunge -S "$dir/run/munge.socket" >/dev/null 2>&1 && break
        sleep 0.1
    done
    munge -n -S "$dir/run/munge.socket" 2>/dev/null | unmunge -S "$dir/run/munge.socket" >/dev/null 2>&1 ||
        fail "munged does not answer on $dir/run/munge.socket"

    # -c: start with no jobs from an earlier run of this directory.
    slurmctld -c -f "$conf" </dev/null >>"$dir/log/slurmctld.log" 2>&1 || fail "slurmctld did not start"
    env SLURM_CONF="$conf" slurmd -f "$conf" -N localhost </dev/null >>"$dir/log/slurmd.log" 2>&1 ||
        fail "slurmd did not start"
fi

# --- wait for the node ---------------------------------------------------------------
deadline=$((SECONDS + timeout))
grace=$((SECONDS + 3))
state=
while :; do
    state=$(sinfo -h -n localhost -o %T 2>/dev/null | head -n 1) || state=
    case $state in idle | mixed | allocated | completing) break ;; esac
    # (a daemon writes its pid file just after it forks, so give them a moment)
    if [ "$SECONDS" -ge "$grace" ]; then
        for d in munged slurmctld slurmd; do
            alive "$d" >/dev/null ||
                fail "$d is not running (node state: ${state:-none})$(last_error "$d")"
        done
    fi
    [ "$SECONDS" -lt "$deadline" ] || fail "node not idle after ${timeout}s (state: ${state:-no answer from slurmctld})"
    sleep 0.2
done

version=$(scontrol version 2>/dev/null | awk '{print $NF}')
cpus=$(sinfo -h -n localhost -o %c 2>/dev/null | head -n 1)
echo "slurm: up (${version:-unknown version}, ${cpus:-?} cpus)"
