# shellcheck shell=bash disable=SC2154 # $dir is set by the script that sources this
# Shared by slurm-up.sh and slurm-down.sh (sourced; they set $dir, the cluster's folder).

# The pid in $dir/run/NAME.pid, if that process is alive and is NAME.
alive() {
    local pid stat
    pid=$(cat "$dir/run/$1.pid" 2>/dev/null) || return 1
    case $pid in '' | *[!0-9]*) return 1 ;; esac
    [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$1" ] || return 1
    stat=$(cat "/proc/$pid/stat" 2>/dev/null) || return 1
    stat=${stat##*) }
    [ "${stat%% *}" != Z ] || return 1 # exited, not yet reaped
    echo "$pid"
}
