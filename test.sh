#!/usr/bin/env bash
# shellcheck disable=SC2015 # `A && B || C` here means "C unless both A and B succeed"
# The one test command: every test of the project, from a fresh checkout.
#
#   ./test.sh              every stage
#   ./test.sh STAGE...     only these stages: rust, python, javascript, browser, slurm,
#                          container, install
#
# Set-up first, for the stages chosen only: checks the tools (a Rust toolchain; Python
# 3.9+ for rust, python and slurm; Node.js 20+ for rust, javascript and browser; npm for
# browser) and installs what those stages need: for python, a virtualenv under target/
# (the system's Python is left alone) with maturin, pytest, NumPy, Gymnasium, PettingZoo,
# SuperSuit, JAX and optax and the rest, and the package's wheel built and installed into
# it; for browser, the browser tests' npm packages and Debian's Chromium and Caddy
# (through apt-get, as root or with sudo that needs no password); for python, javascript,
# browser, slurm, container and install, the release binary; for container, Debian's buildah
# and debootstrap. `rust` needs none of these. What it cannot install it names, in one line,
# with how to get it, and stops.
# Then the stages, in this order: the Rust tests, the Python suite (against the wheel),
# the JavaScript client suite, the browser tests, and a tournament as a Slurm job array
# on a one-node cluster it starts (Debian's Slurm and munge, as root or with sudo), the
# container image built and run (container/build.sh, as root), and `cargo install` of the
# command into target/install from the release build. A failing stage does not stop the later ones; the exit status is 0 only when every stage
# run passed (2 for a usage error or a missing tool).
#
# BW4T_ORIGINAL_MAPS=DIR also runs the Rust tests on the original BW4T map files in DIR
# with the rust stage (without it they are listed as ignored). Runs unattended (CI=true,
# no input).
set -euo pipefail

# Resolve the original maps folder against the caller's directory, before moving.
original_maps=${BW4T_ORIGINAL_MAPS:-}
if [ -n "$original_maps" ]; then
    if [ ! -d "$original_maps" ]; then
        echo "test.sh: BW4T_ORIGINAL_MAPS=$original_maps is not a folder (it must name the folder of the original BW4T map files)" >&2
        exit 2
    fi
    original_maps=$(cd "$original_maps" && pwd)
fi

# The stages, in the order they run; no argument chooses them all.
all_stages=(rust python javascript browser slurm container install)
chosen=()
for arg in "$@"; do
    case $arg in
        -h | --help)
            sed -n '3,/^set -euo/{/^#/{s/^# \{0,1\}//;p}}' "$0"
            exit 0
            ;;
        rust | python | javascript | browser | slurm | container | install) chosen+=("$arg") ;;
        *)
            echo "test.sh: unknown stage '$arg'; the stages are: ${all_stages[*]} (none for all)" >&2
            exit 2
            ;;
    esac
done
[ ${#chosen[@]} -gt 0 ] || chosen=("${all_stages[@]}")
# Whether any of the named stages was chosen.
wants() {
    local stage
    for stage in "$@"; do
        case " ${chosen[*]} " in *" $stage "*) return 0 ;; esac
    done
    return 1
}

cd "$(dirname "$0")"
root=$PWD
target=${CARGO_TARGET_DIR:-target}
case $target in /*) ;; *) target=$root/$target ;; esac

started=$SECONDS
stage_started=$SECONDS
heading() {
    printf '\n==> %s\n' "$*"
    stage_started=$SECONDS
}
took() { printf '    (%d s)\n' $((SECONDS - stage_started)); }
# What is missing and how to get it, in one line; then stop.
missing() {
    echo "test.sh: missing $*" >&2
    exit 2
}
# Root runs apt-get itself; anyone else needs sudo that asks for no password.
as_root() {
    if [ "$(id -u)" = 0 ]; then
        "$@"
    elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
        sudo "$@"
    else
        return 1
    fi
}
apt_log=$target/test-apt.log
apt_install() {
    command -v apt-get >/dev/null || return 1
    mkdir -p "$target"
    {
        as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq &&
            as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@"
    } >"$apt_log" 2>&1
}

heading "Set-up: tools and test dependencies (stages: ${chosen[*]})"
command -v cargo >/dev/null ||
    missing "cargo: install a Rust toolchain (1.87 or newer) from https://rustup.rs"
if wants rust python slurm; then
    command -v python3 >/dev/null && python3 -c 'import sys; sys.exit(sys.version_info < (3, 9))' ||
        missing "Python 3.9 or newer as python3: apt-get install python3 python3-venv (or https://www.python.org)"
fi
if wants rust javascript browser; then
    command -v node >/dev/null && node -e 'process.exit(Number(process.versions.node.split(".")[0]) >= 20 ? 0 : 1)' ||
        missing "Node.js 20 or newer as node: https://nodejs.org (or apt-get install nodejs npm on Debian 13)"
fi
if wants browser; then
    command -v npm >/dev/null || missing "npm (it comes with Node.js): apt-get install npm, or https://nodejs.org"
fi

if wants python; then
    # Python: the tools to build the wheel and the test suite's packages, in a virtualenv.
    venv=$target/test-venv
    python=$venv/bin/python
    # A virtualenv left by a Python that is gone is made anew.
    [ -x "$python" ] && "$python" -c '' 2>/dev/null || rm -rf "$venv"
    if [ ! -x "$python" ]; then
        mkdir -p "$target"
        if ! python3 -m venv "$venv" >/dev/null 2>&1; then
            rm -rf "$venv"
            # Debian keeps venv in its own package.
            apt_install python3-venv && python3 -m venv "$venv" >/dev/null 2>&1 || rm -rf "$venv"
        fi
    fi
    pip_log=$target/test-pip.log
    if [ -x "$python" ]; then
        pip=("$python" -m pip install --quiet --disable-pip-version-check --no-input)
        # What the package needs (pyproject.toml), its test and training extras, maturin.
        if ! "${pip[@]}" 'maturin>=1.9,<2' pytest numpy 'gymnasium>=1.1' 'pettingzoo>=1.24' 'supersuit>=3.9' jax optax 'mcp>=2.3; python_version >= "3.10"' 'minari[hdf5]>=0.5; python_version >= "3.11"' 'pillow; python_version >= "3.11"' 'kubernetes-validate>=1.30' 'auditwheel>=6' \
            >"$pip_log" 2>&1; then
            missing "maturin, pytest, numpy, gymnasium, pettingzoo, supersuit, jax, optax, mcp, minari, kubernetes-validate or auditwheel in $venv: pip could not install them from PyPI (see $pip_log)"
        fi
        echo "    Python: $("$python" --version), with maturin, pytest, NumPy, Gymnasium, PettingZoo, SuperSuit, JAX, the MCP SDK, Minari, kubernetes-validate and auditwheel in $venv"
    else
        missing "python3 -m venv: apt-get install python3-venv"
    fi
fi

if wants browser; then
    # Browser tests: Debian's Chromium (where the tests look for it) and playwright-core.
    chromium=/usr/bin/chromium
    if [ ! -x "$chromium" ]; then
        echo "    installing Debian's chromium (apt-get)"
        apt_install chromium && [ -x "$chromium" ] ||
            missing "Chromium at $chromium: sudo apt-get install chromium (Debian's package; this try's output is in $apt_log)"
    fi
    echo "    Chromium: $("$chromium" --version 2>/dev/null || echo "$chromium")"
    # The deployment test (tests/browser/deploy.test.js) puts Debian's Caddy in front of bw4t.
    if ! command -v caddy >/dev/null; then
        echo "    installing Debian's caddy (apt-get)"
        apt_install caddy && command -v caddy >/dev/null ||
            missing "caddy: sudo apt-get install caddy (Debian's package; this try's output is in $apt_log)"
    fi
    echo "    Caddy: $(caddy version 2>/dev/null | head -n 1)"
    browser=tests/browser
    if [ ! "$browser/node_modules/.package-lock.json" -nt "$browser/package-lock.json" ]; then
        (cd "$browser" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --silent) ||
            missing "the browser tests' npm packages: (cd $browser && npm ci) failed; the npm registry must be reachable"
    fi
    echo "    Node.js $(node --version), playwright-core and the MCP Inspector in $browser/node_modules"
fi
took

if wants python javascript browser slurm container install; then
    heading "Build the release binary: cargo build --release --locked"
    cargo build --release --locked
    export BW4T_BIN=$target/release/bw4t
    took
fi

if wants python; then
    heading "Build and install the Python package: maturin build (pyproject.toml, python/), pip install the wheel"
    wheels=$target/wheels
    rm -f "$wheels"/bw4t-*.whl
    "$venv/bin/maturin" build --release --locked --quiet -o "$wheels"
    "${pip[@]}" --force-reinstall --no-deps "$wheels"/bw4t-*.whl
    echo "    $(basename "$wheels"/bw4t-*.whl) installed in $venv"
    # The packaging tests check this very file (its manylinux tag).
    BW4T_WHEEL=$(ls "$wheels"/bw4t-*.whl)
    export BW4T_WHEEL
    took
fi

passed=()
failed=()
# Runs one test stage; a failure is recorded and the next stage still runs.
stage() {
    local name=$1
    shift
    if "$@"; then passed+=("$name"); else failed+=("$name"); fi
    took
}

if wants rust; then
    heading "Rust tests: cargo test --workspace --locked"
    stage rust cargo test --workspace --locked

    if [ -n "$original_maps" ]; then
        heading "Rust tests on the original BW4T maps in $original_maps"
        # --workspace: the same features as the run above, so the same test binary, not a
        # second build of it.
        stage original-maps env BW4T_ORIGINAL_MAPS="$original_maps" \
            cargo test --workspace --locked --test main -- --ignored original_maps::
    else
        heading "Rust tests on the original BW4T maps: skipped"
        echo "    BW4T_ORIGINAL_MAPS is not set; the original_maps:: tests above are listed as ignored."
        echo "    Set it to the folder of the original BW4T map files to run them."
    fi
fi

if wants python; then
    heading "Python package: pytest python/tests (the installed wheel: environments, match, client, command)"
    # The virtualenv's pytest script (not `python -m`), so `bw4t` is the wheel, not python/bw4t.
    stage python "$venv/bin/pytest" -q -p no:cacheprovider python/tests
fi

if wants javascript; then
    heading "JavaScript client: node --test protocol/clients/js/test/"
    stage javascript node --test protocol/clients/js/test/
fi

if wants browser; then
    heading "Browser tests: node --test tests/browser/ (screenshots in test-output/browser/)"
    stage browser node --test "$browser/"
fi

if wants slurm; then
    heading "Slurm: a tournament as a job array on a one-node cluster (tests/cluster/slurm-tournament.sh)"
    # Installs Debian's Slurm and munge and starts them (as root or with sudo; skipped, and
    # said so, without), and stops them again.
    stage slurm bash tests/cluster/slurm-tournament.sh
fi

if wants container; then
    heading "Container image: the Containerfile built with buildah and run (container/build.sh)"
    # buildah keeps its images in root's storage; without root it says so and is skipped.
    if [ "$(id -u)" != 0 ]; then
        echo "    skipped: building the image needs root (buildah's storage and debootstrap)"
    elif command -v buildah >/dev/null && command -v debootstrap >/dev/null ||
        apt_install buildah debootstrap; then
        stage container container/build.sh
    else
        echo "    buildah or debootstrap could not be installed (apt-get; its output is in $apt_log)" >&2
        failed+=(container)
    fi
fi

if wants install; then
    heading "Install: cargo install --path crates/bw4t-cli --locked (into target/install)"
    # The release build's target directory, so the install reuses what it built.
    install_command() {
        CARGO_TARGET_DIR=$target cargo install --quiet --locked --force \
            --path crates/bw4t-cli --root "$target/install" &&
            echo "    installed: $("$target/install/bin/bw4t" --version)"
    }
    stage install install_command
fi

printf '\n==> Done in %d s\n' $((SECONDS - started))
if [ ${#passed[@]} -gt 0 ]; then echo "    passed: ${passed[*]}"; fi
if [ ${#failed[@]} -gt 0 ]; then
    echo "    FAILED: ${failed[*]}"
    exit 1
fi
