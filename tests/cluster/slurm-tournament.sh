#!/usr/bin/env bash
# A small tournament as a real Slurm job array, on a one-node cluster started here:
# `bw4t tournament slurm` writes the array and the merge job, submit.sh submits them, and
# every merged row must equal the unsharded run's row for the same match (same digest).
# Prints figures as JSON lines: matches per minute unsharded on 1 and on 2 cores, and
# through the array (the array's overhead included).
#
#   tests/cluster/slurm-tournament.sh [CLUSTER_DIR]     (default target/slurm)
#
# Uses $BW4T_BIN (default target/release/bw4t). Needs root or password-less sudo to start
# Slurm: without, it says so and exits 0 (skipped). Exits 1 on any difference.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
cluster=${1:-$repo/target/slurm}
bw4t=$(realpath "${BW4T_BIN:-$repo/target/release/bw4t}")
# Seconds the array and the merge may take in all before the test gives up.
limit=${SLURM_TOURNAMENT_TIMEOUT:-600}

set +e
bash "$here/slurm-up.sh" "$cluster"
up=$?
set -e
if [ "$up" = 3 ]; then
    echo "slurm tournament: skipped (starting Slurm needs root or password-less sudo)"
    exit 0
elif [ "$up" != 0 ]; then
    echo "slurm tournament: FAILED: the cluster did not start" >&2
    exit 1
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/bw4t-slurm-XXXXXX")
trap 'bash "$here/slurm-down.sh" "$cluster" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
# shellcheck source=/dev/null
source "$cluster/env.sh"

cat >"$work/tournament.toml" <<'TOML'
maps = ["fixed", "default"]
seeds = 25

[[team]]
name = "coop"
agents = "builtin"
robots = 3

[[team]]
name = "solo"
agents = "builtin:baseline"
robots = 2
TOML
matches=100

# Seconds since the epoch, with fractions.
now() { date +%s.%N; }
# A figure line: what ran, its workers (cores or tasks), when it started, its matches.
figure() {
    python3 -c 'import json,sys,time; p,n,t,m=sys.argv[1],int(sys.argv[2]),float(sys.argv[3]),int(sys.argv[4]); s=time.time()-t; print(json.dumps({"case":"tournament","path":p,"workers":n,"matches":m,"seconds":round(s,2),"matches_per_min":round(m*60/s)}))' "$@"
}

for cores in 1 2; do
    started=$(now)
    "$bw4t" tournament "$work/tournament.toml" --out "$work/whole-$cores" --concurrency "$cores" --replays none >/dev/null 2>&1
    figure "unsharded, --concurrency $cores" "$cores" "$started" "$matches"
done

tasks=4
"$bw4t" tournament slurm "$work/tournament.toml" --array "$tasks" --out "$work/array" --bw4t "$bw4t" >/dev/null
started=$(now)
submitted=$(sh "$work/array/slurm/submit.sh")
echo "    $submitted"
read -r array merge < <(echo "$submitted" | sed -E 's/.*job array ([0-9]+) .*merge job ([0-9]+).*/\1 \2/')
# Wait for both jobs to leave the queue, bounded.
deadline=$((SECONDS + limit))
while [ -n "$(squeue -h -j "$array,$merge" 2>/dev/null)" ]; do
    if [ "$SECONDS" -ge "$deadline" ]; then
        echo "slurm tournament: FAILED: the jobs did not finish within $limit s" >&2
        squeue >&2 || true
        exit 1
    fi
    sleep 0.2
done
figure "slurm job array of $tasks tasks, then the merge job" "$tasks" "$started" "$matches"

state=$(scontrol show job "$merge" | sed -nE 's/.*JobState=([A-Z_]+).*/\1/p' | head -n1)
if [ "$state" != COMPLETED ] || [ ! -f "$work/array/merged/matches.jsonl" ]; then
    echo "slurm tournament: FAILED: the merge job ended $state" >&2
    cat "$work/array/slurm/"*.log >&2 || true
    exit 1
fi
python3 - "$work/whole-1/matches.jsonl" "$work/array/merged/matches.jsonl" <<'PY'
import json, sys
def rows(path):
    return {r["key"]: r for r in map(json.loads, open(path))}
whole, merged = rows(sys.argv[1]), rows(sys.argv[2])
machine = {"wall_ms"}  # how long a match took depends on the machine, nothing else does
differ = [k for k in whole if {f: v for f, v in whole[k].items() if f not in machine} != {f: v for f, v in merged.get(k, {}).items() if f not in machine}]
if set(whole) != set(merged) or differ:
    print(f"slurm tournament: FAILED: {len(set(whole) ^ set(merged))} keys differ, {len(differ)} rows differ, e.g. {differ[:3]}", file=sys.stderr)
    sys.exit(1)
print(f"    slurm tournament: all {len(merged)} merged rows equal the unsharded run's")
PY
