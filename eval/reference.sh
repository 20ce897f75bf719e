#!/usr/bin/env bash
# Plays every reference row of the suite: each built-in strategy a tier admits and the
# random player, on both splits of every tier, and the PPO example's default run on the
# `learn` tier, into eval/reference.jsonl (one row a line).
# `tests/eval.rs` plays the `solo` rows again and checks they come out the same.
#   [PYTHON=...] eval/reference.sh [BW4T_BINARY]
set -euo pipefail
bin=${1:-target/release/bw4t}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
out=$here/reference.jsonl
: >"$out.new"
for tier in $("$bin" eval tiers --json | python3 -c 'import json,sys; print(" ".join(json.loads(l)["tier"] for l in sys.stdin))'); do
    for split in dev test; do
        for agent in coop silent ignoring baseline random; do
            dir=$work/$tier-$split-$agent
            if "$bin" eval "$tier" --agent "builtin:$agent" --split "$split" --out "$dir" >"$dir.row" 2>"$dir.err"; then
                cat "$dir.row" >>"$out.new"
            elif grep -q "allows no messages" "$dir.err"; then
                continue
            else
                cat "$dir.err" >&2
                exit 1
            fi
        done
    done
done
# The PPO example's default run, greedy on the `learn` tier (about 3 minutes of training):
# with a Python that has bw4t (this checkout's) and JAX, e.g. PYTHON=target/test-venv/bin/python.
python=${PYTHON:-python3}
"$python" "$here/../python/examples/train_ppo.py" --eval-tier learn --eval-split dev,test --eval-out "$work/ppo" \
    | grep '^{"eval"' | "$python" -c 'import json,sys; [print(json.dumps(json.loads(l)["eval"], separators=(",", ":"))) for l in sys.stdin]' \
    >>"$out.new"
mv "$out.new" "$out"
echo "wrote $(wc -l <"$out") rows to $out" >&2
