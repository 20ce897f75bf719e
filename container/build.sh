#!/usr/bin/env bash
# Builds the bw4t image from the Containerfile with buildah (no daemon needed) and checks
# it as a cluster would use it: a user without privileges, the same match as the host's
# binary, the Python package, and the Kubernetes manifests' own commands.
#
#   container/build.sh [IMAGE]      (default localhost/bw4t:VERSION, VERSION from Cargo.toml)
#
# Where no image registry is reachable, the Debian base is made from Debian's packages
# (container/debian-base.sh). The host's target directory and crate cache are mounted into
# the build, so after `cargo build --release` the image costs little more than its layers.
# Needs root (buildah's storage), buildah and debootstrap; BW4T_BIN, a release bw4t.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -n 1)
image=${1:-localhost/bw4t:$version}
bw4t=${BW4T_BIN:-$root/target/release/bw4t}
cargo_home=${CARGO_HOME:-$HOME/.cargo}
# Without cgroup delegation (inside a VM's sandbox or another container) OCI runtimes
# cannot start; chroot isolation runs the build's steps all the same.
isolation=(--isolation chroot)

step() { echo "    $*"; }
fail() {
    echo "container: $*" >&2
    exit 1
}

official=docker.io/library/debian:bookworm-slim
if buildah pull --quiet "$official" >/dev/null 2>&1; then
    base=$official
else
    step "no registry reachable for $official: a base from Debian's packages (container/debian-base.sh)"
    base=$(container/debian-base.sh)
fi

build_args=(--build-arg "DEBIAN=$base" --build-arg "SRC=$root" --build-arg "CARGO_HOME=$cargo_home")
build_args+=(--build-arg "RUST_VERSION=$(rustc --version | cut -d' ' -f2)")
mounts=(-v "$root/target:$root/target" -v "$cargo_home/registry:$cargo_home/registry")
# The host's trust store, for a TLS-inspecting proxy between this machine and the registries.
host_ca=/etc/ssl/certs/ca-certificates.crt
if [ -f "$host_ca" ]; then
    mounts+=(-v "$host_ca:/etc/bw4t-host-ca.crt:ro")
    for variable in SSL_CERT_FILE CURL_CA_BUNDLE PIP_CERT CARGO_HTTP_CAINFO; do
        build_args+=(--build-arg "$variable=/etc/bw4t-host-ca.crt")
    done
fi

log=$root/target/container-build.log
step "buildah build -t $image (base $base; its output in ${log#"$root"/})"
buildah build --layers "${isolation[@]}" "${build_args[@]}" "${mounts[@]}" \
    -f Containerfile -t "$image" . >"$log" 2>&1 || fail "the build failed: $(tail -n 20 "$log")"

work=$(mktemp -d)
container=
cleanup() {
    [ -n "$container" ] && buildah rm "$container" >/dev/null 2>&1
    rm -rf "$work"
}
trap cleanup EXIT
container=$(buildah from --quiet "$image")
# Runs a command in the image as its own user, with the image's entry point's PATH.
in_image() { buildah run "${isolation[@]}" "${extra_mounts[@]}" "$container" -- "$@"; }
extra_mounts=()

user=$(buildah inspect --format '{{.OCIv1.Config.User}}' "$image")
uid=$(in_image id -u)
if [ "$user" != 10001:10001 ] || [ "$uid" != 10001 ]; then
    fail "the image runs as '$user' (uid $uid), not as the user bw4t (10001)"
fi
step "runs as $(in_image id -un) ($user), not root"

# The same match, bit for bit, as the host's binary: the digest and the tick it completed.
summary='import json, sys; r = json.load(sys.stdin); print(r["digest"], r["completed_tick"], r["end_reason"])'
inside=$(in_image bw4t run --map fixed --seed 7 --json | python3 -c "$summary")
outside=$("$bw4t" run --map fixed --seed 7 --json | python3 -c "$summary")
[ "$inside" = "$outside" ] || fail "bw4t run in the image gave '$inside', the host's binary '$outside'"
step "bw4t run --map fixed --seed 7: $inside, as on the host"

# The Python package with its rl extra: an in-process match and a PettingZoo environment.
python_check='
import bw4t.sim, bw4t.env
env = bw4t.env.parallel_env(map="fixed", robots=1)
obs, _ = env.reset(seed=7)
(agent,) = env.agents
assert obs[agent]["action_mask"].any(), "no action allowed at the start"
print(agent)'
agent=$(in_image python3 -c "$python_check") || fail "the Python package in the image failed: $agent"
step "import bw4t.sim, bw4t.env: a parallel_env with $agent"

# The Kubernetes manifests' own commands, as the pods run them: two shards of an Indexed
# Job, then the merge, on a shared results volume that the image's user may write.
printf 'maps = ["fixed"]\nseeds = 4\n[[team]]\nname = "coop"\nagents = "builtin"\n' >"$work/tournament.toml"
"$bw4t" tournament k8s "$work/tournament.toml" --completions 2 --image "$image" --out "$work/k8s" >/dev/null
mkdir -p "$work/config" "$work/results"
# What a pod gets from the manifests: the configuration file, and each job's image, variables
# and command (one word a line).
python3 - "$work" <<'EOF'
import json, pathlib, sys
work = pathlib.Path(sys.argv[1])
def load(name):
    return json.loads((work / "k8s" / name).read_text())
(work / "config" / "tournament.toml").write_text(load("configmap.json")["data"]["tournament.toml"])
for job in ("shards", "merge"):
    container = load(f"{job}-job.json")["spec"]["template"]["spec"]["containers"][0]
    (work / f"{job}.image").write_text(container["image"])
    words = [f"{v['name']}={v['value']}" for v in container.get("env", [])] + container["command"]
    (work / f"{job}.command").write_text("\n".join(words) + "\n")
EOF
[ "$(cat "$work/shards.image")" = "$image" ] || fail "the manifests name $(cat "$work/shards.image"), not $image"
chown "$uid" "$work/results"
extra_mounts=(-v "$work/config:/config:ro" -v "$work/results:/results")
mapfile -t shard_command <"$work/shards.command"
mapfile -t merge_command <"$work/merge.command"
for index in 0 1; do
    in_image env JOB_COMPLETION_INDEX=$index "${shard_command[@]}" >"$work/shard-$index.log" 2>&1 ||
        fail "shard $index of the Indexed Job failed: $(tail -n 5 "$work/shard-$index.log")"
done
in_image env "${merge_command[@]}" >"$work/merge.log" 2>&1 || fail "the merge job failed: $(tail -n 5 "$work/merge.log")"
rows=$(wc -l <"$work/results/bw4t-tournament/merged/matches.jsonl")
[ "$rows" = 4 ] || fail "the merged tournament has $rows rows, not 4"
step "the Kubernetes jobs' commands: 2 shards and the merge, $rows matches"
echo "    $image: $(buildah images --format '{{.Size}}' "$image")"
