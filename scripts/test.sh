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
# The Python extension module is tested from Python (below): a Rust test harness would have to
# link libpython.
cargo test --release "${checks[@]}" --workspace --exclude sonarproj-py --all-targets "$@"
cargo test --release "${checks[@]}" --workspace --exclude sonarproj-py --doc "$@"
# The GPU's double-f32 path (that of GPUs without f64), forced on lavapipe, against its envelope.
SONARPROJ_GPU_PRECISION=df cargo test --release "${checks[@]}" --test agreement "$@"

# Python: the package built as an abi3 manylinux wheel from the same target directory (the
# dependencies built above are reused), installed into a fresh virtual environment, then its
# tests (against the binary built above) and the Python examples.
target_dir="${CARGO_TARGET_DIR:-$PWD/target}"
venv="$target_dir/python-venv"
wheels="$target_dir/wheels"
rm -rf "$venv" "$wheels"
"${PYTHON:-python3}" -m venv "$venv"
"$venv/bin/pip" install -q --disable-pip-version-check "maturin>=1.9,<2" numpy pytest matplotlib "selenium>=4.20,<5" pyarrow
"$venv/bin/maturin" build --release --quiet "${checks[@]}" -o "$wheels"
"$venv/bin/pip" install -q --disable-pip-version-check --no-deps "$wheels"/sonarproj-*.whl
SONARPROJ_BIN="$target_dir/release/sonarproj" "$venv/bin/pytest" -q python/tests
# The README's Slurm recipe on a real single-node cluster started and stopped by the script.
bash scripts/test_slurm.sh "$target_dir/release/sonarproj"
# The viewer (`sonarproj view`) driven in headless Chromium.
SONARPROJ_BIN="$target_dir/release/sonarproj" "$venv/bin/pytest" -q web/tests
examples_out="$(mktemp -d)"
trap 'rm -rf "$examples_out"' EXIT
for example in examples/python/*.py; do
    echo "example: $example" >&2
    MPLBACKEND=Agg "$venv/bin/python" "$example" --out "$examples_out/$(basename "$example" .py)" >/dev/null
done
