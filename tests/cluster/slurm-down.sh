#!/usr/bin/env bash
# Stop the one-node Slurm cluster that tests/cluster/slurm-up.sh started in DIR.
#
#   tests/cluster/slurm-down.sh [DIR]      (DIR defaults to target/slurm in the repository)
#
# Cancels the cluster's jobs and waits (bounded) for them to end, kills any slurmstepd
# left over from this cluster (found by SLURM_CONF=DIR/slurm.conf in its environment)
# with its job's process group, then stops slurmd, slurmctld and munged by the pids in
# DIR/run/*.pid (TERM, then KILL after 15 s). Leaves DIR, with its logs, in place.
# Prints `slurm: down`; exits 0 when nothing was running too, 1 if something could not
# be stopped, 3 when not root and no password-less sudo.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
dir=${1:-$repo/target/slurm}

if [ ! -d "$dir" ]; then
    echo "slurm: down (nothing in $dir)"
    exit 0
fi
dir=$(cd "$dir" && pwd)

if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        exec sudo -n bash "${BASH_SOURCE[0]}" "$dir"
    fi
    echo "slurm: needs root or password-less sudo to stop Slurm (running as $(id -un))" >&2
    exit 3
fi

conf=$dir/slurm.conf

# shellcheck source=tests/cluster/lib.sh
source "$here/lib.sh"

# Whether a pid has exited (a zombie counts: here PID 1 may take seconds to reap it).
gone() {
    local stat
    stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 0
    stat=${stat##*) }
    [ "${stat%% *}" = Z ]
}

# Stop the given pids: TERM, wait up to 15 s, then KILL and wait up to 5 s more.
stop() {
    local pid left n
    [ $# -gt 0 ] || return 0
    kill -TERM "$@" 2>/dev/null || true
    for n in $(seq 200); do
        left=()
        for pid in "$@"; do gone "$pid" || left+=("$pid"); done
        [ ${#left[@]} -gt 0 ] || return 0
        [ "$n" -ne 150 ] || kill -KILL "${left[@]}" 2>/dev/null || true
        sleep 0.1
    done
    return 1
}

# slurmstepd processes of this cluster.
stepds() {
    local p
    for p in /proc/[0-9]*; do
        [ "$(cat "$p/comm" 2>/dev/null)" = slurmstepd ] || continue
        { tr '\0' '\n' <"$p/environ"; } 2>/dev/null | grep -qxF "SLURM_CONF=$conf" && echo "${p#/proc/}"
    done
    return 0
}

# The process groups of the children of the given pids.
groups_of() {
    local p stat rest ppid pgrp
    for p in /proc/[0-9]*; do
        stat=$(cat "$p/stat" 2>/dev/null) || continue
        rest=${stat##*) }
        read -r _ ppid pgrp _ <<<"$rest"
        for parent in "$@"; do
            [ "$ppid" = "$parent" ] && [ "$pgrp" -gt 1 ] && echo "$pgrp"
        done
    done | sort -u
    return 0
}

# 1. Jobs first: slurmd does not exit while a job is still being torn down, and a
# slurmstepd whose slurmctld has gone retries for ever.
if [ -f "$conf" ] && alive slurmctld >/dev/null; then
    export SLURM_CONF=$conf
    jobs=$(squeue -h -o %F 2>/dev/null | sort -u | tr '\n' ' ') || jobs=
    if [ -n "${jobs// /}" ]; then
        # shellcheck disable=SC2086 # one word per job id
        scancel $jobs 2>/dev/null || true
        for _ in $(seq 150); do
            [ -z "$(squeue -h 2>/dev/null)" ] && break
            sleep 0.2
        done
    fi
fi

# 2. Steps left over (slurmctld gone before their jobs ended): end their jobs' process
# groups (proctrack/pgid puts each job in one) and the steps themselves.
ok=1
mapfile -t left < <(stepds)
if [ ${#left[@]} -gt 0 ]; then
    mapfile -t groups < <(groups_of "${left[@]}")
    for g in "${groups[@]}"; do kill -KILL -- "-$g" 2>/dev/null || true; done
    kill -KILL "${left[@]}" 2>/dev/null || true
    stop "${left[@]}" || { echo "slurm: slurmstepd (pids ${left[*]}) would not stop" >&2; ok=; }
fi

# 3. Daemons, the node first.
for d in slurmd slurmctld; do
    if pid=$(alive "$d"); then
        stop "$pid" || { echo "slurm: $d (pid $pid) would not stop" >&2; ok=; }
    fi
done
if pid=$(alive munged); then
    stop "$pid" || { echo "slurm: munged (pid $pid) would not stop" >&2; ok=; }
fi

[ -n "$ok" ] || exit 1
rm -f "$dir/run/"*.pid "$dir/run/munge.socket" "$dir/run/munge.socket.lock"
echo "slurm: down"
