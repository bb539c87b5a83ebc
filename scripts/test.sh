#!/usr/bin/env bash
# Runs the whole test suite, GPU tests on lavapipe (Mesa's Vulkan CPU driver), installing it when
# it is missing. Usage: scripts/test.sh [extra cargo test arguments]
set -euo pipefail
cd "$(dirname "$0")/.."

if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
    echo "lavapipe not found: installing mesa-vulkan-drivers" >&2
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
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
for p in sonarproj sonarproj-apps sonarproj-cli; do
    checks+=(--config "profile.release.package.$p.overflow-checks=true")
done
cargo build --release "${checks[@]}" --examples
cargo test --release "${checks[@]}" --workspace --all-targets "$@"
cargo test --release "${checks[@]}" --workspace --doc "$@"
