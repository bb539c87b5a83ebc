#!/usr/bin/env bash
# Runs the whole test suite — Rust, then the Python package's, a sweep on a real Slurm cluster,
# then the viewer's in a browser —
# with GPU tests on lavapipe (Mesa's Vulkan CPU driver), installing what is missing. Usage: scripts/test.sh [extra cargo
# test arguments]
set -euo pipefail
cd "$(dirname "$0")/.."

# System packages: lavapipe (Mesa's Vulkan CPU driver) for the GPU tests, Chromium and its
# WebDriver for the viewer's browser tests.
missing=()
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || missing+=(mesa-vulkan-drivers libvulkan1)
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
command -v chromedriver >/dev/null 2>&1 || missing+=(chromium-driver)
if [ "${#missing[@]}" -gt 0 ]; then
    echo "installing ${missing[*]} (apt)" >&2
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# Vulkan is the backend that has lavapipe; the device-select layer only prints noise headless.
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}"
export NODEVICE_SELECT=1

# The release profile, so the tests reuse the dependency tree that `cargo run --release` built
# (a debug build would compile it all again); overflow checks on for the workspace's own crates
# alone, which leaves the dependencies' builds untouched (the shipped binary runs without them:
# 25 % faster). The examples are built as programs first (`cargo test` builds them only as test
# harnesses), for tests/examples.rs to run; doctests last.
checks=()
for p in sonarproj sonarproj-apps sonarproj-cli sonarproj-py sonarproj-testkit; do
    checks+=(--config "profile.release.package.$p.overflow-checks=true")
done
cargo build --release "${checks[@]}" --examples

# Each stage's output is shown as it runs and kept in a log, from which its counts are read for
# the summary line at the end. A failing stage does not stop the others; the script then exits 1.
logs="$(mktemp -d)"
examples_out="$(mktemp -d)"
trap 'rm -rf "$logs" "$examples_out"' EXIT
status=0
broke=" "
# stage NAME CMD...: runs CMD, its output also appended to $logs/NAME.log.
stage() {
    local name=$1
    shift
    "$@" 2>&1 | tee -a "$logs/$name.log" || { broke+="$name "; status=1; }
}

# The Python extension module is tested from Python (below): a Rust test harness would have to
# link libpython.
stage rust cargo test --release "${checks[@]}" --workspace --exclude sonarproj-py --all-targets "$@"
stage rust cargo test --release "${checks[@]}" --workspace --exclude sonarproj-py --doc "$@"
# The GPU's double-f32 path (that of GPUs without f64), forced on lavapipe, against its envelope.
stage rust env SONARPROJ_GPU_PRECISION=df cargo test --release "${checks[@]}" --test agreement "$@"

# Python: the package built as an abi3 manylinux wheel from the same target directory (the
# dependencies built above are reused), installed into a fresh virtual environment, then its
# tests (against the binary built above) and the Python examples.
target_dir="${CARGO_TARGET_DIR:-$PWD/target}"
venv="$target_dir/python-venv"
wheels="$target_dir/wheels"
rm -rf "$venv" "$wheels"
"${PYTHON:-python3}" -m venv "$venv"
"$venv/bin/pip" install -q --disable-pip-version-check "maturin>=1.9,<2" numpy pytest matplotlib "selenium>=4.20,<5" pyarrow "mcap-ros2-support>=0.5,<1"
"$venv/bin/maturin" build --release --quiet "${checks[@]}" -o "$wheels"
"$venv/bin/pip" install -q --disable-pip-version-check --no-deps "$wheels"/sonarproj-*.whl
stage python env SONARPROJ_BIN="$target_dir/release/sonarproj" "$venv/bin/pytest" -q python/tests
# The examples' own notes (a CPU fallback) are kept in their log, shown when one fails.
examples=(0 0)
for example in examples/python/*.py; do
    name="$(basename "$example" .py)"
    if MPLBACKEND=Agg "$venv/bin/python" "$example" --out "$examples_out/$name" \
        >"$logs/example-$name.log" 2>&1; then
        echo "example $name: passed"
        examples[0]=$((examples[0] + 1))
    else
        echo "example $name: FAILED" >&2
        cat "$logs/example-$name.log" >&2
        examples[1]=$((examples[1] + 1))
        broke+="examples "
        status=1
    fi
done
# The guide's Slurm recipe (docs/sweeps.md) on a real single-node cluster started and stopped by the script.
stage slurm bash scripts/test_slurm.sh "$target_dir/release/sonarproj"
# The viewer (`sonarproj view`) driven in headless Chromium.
stage browser env SONARPROJ_BIN="$target_dir/release/sonarproj" "$venv/bin/pytest" -q web/tests

# The summary reads the logs; a pattern found nowhere is a count of 0, not an error.
set +e +o pipefail

# sum: the sum of the numbers on stdin, one a line (0 for none).
sum() { awk '{ s += $1 } END { print s + 0 }'; }

# counts NAME: "P passed, F failed" from the stage's log (cargo's "test result" lines, pytest's
# last line), with a note when the stage failed without a failing test (a build, an import).
counts() {
    local name=$1 log="$logs/$1.log" passed=0 failed=0
    [ -f "$log" ] || { echo "not run"; return; }
    case "$name" in
    rust)
        passed=$(grep -oE '^test result: [A-Za-z]+\. [0-9]+ passed' "$log" | grep -oE '[0-9]+' | sum)
        failed=$(grep -oE '[0-9]+ failed;' "$log" | grep -oE '[0-9]+' | sum)
        ;;
    slurm)
        if [[ "$broke" == *" slurm "* ]]; then failed=1; else passed=1; fi
        ;;
    *)
        local last
        last=$(grep -E '[0-9]+ (passed|failed|errors?)' "$log" | tail -n 1)
        passed=$(grep -oE '[0-9]+ passed' <<<"$last" | grep -oE '[0-9]+' | sum)
        failed=$(grep -oE '[0-9]+ (failed|errors?)' <<<"$last" | grep -oE '[0-9]+' | sum)
        ;;
    esac
    passed=${passed:-0}
    failed=${failed:-0}
    local note=""
    [[ "$broke" == *" $name "* && "$failed" -eq 0 ]] && note=" (it exited with an error)"
    echo "$passed passed, $failed failed$note"
}
echo "test.sh: Rust $(counts rust); Python $(counts python); examples ${examples[0]} passed, ${examples[1]} failed; Slurm $(counts slurm); browser $(counts browser)"
exit "$status"
