#!/usr/bin/env bash
# Runs the GPU checks and measurements on a machine with a real GPU that has no Rust toolchain
# and no network (an NVIDIA H100 lent for half an hour, say), so that its time goes to measuring.
#
#   scripts/gpu-remote.sh prepare   # here: build, strip and pack everything into .gpu/ (< 64 MiB)
#   scripts/gpu-remote.sh run       # there, from the repository root, with .gpu/ copied along:
#                                   # Vulkan loader, NVIDIA ICD, GPU tests (the summaries reduced
#                                   # on the device among them), benches, paper,
#                                   # 1 M-pose sweeps (Parquet, summaries) on GPU and CPU,
#                                   # `bench sweep` on 10 M poses (10^8 with summaries only; exact
#                                   # arcs against 0.1° sampling; each variant's device time a
#                                   # stage),
#                                   # mask --stream with 2000 waiting pings, the advisor's benchmark;
#                                   # summary.txt and logs.tar.gz into $OUT (or .gpu/out)
#
# `prepare` needs cargo and apt-get (for the Vulkan loader packages, unpacked there with dpkg -x).
# `run` needs only the NVIDIA driver on the remote machine; it also works on lavapipe here, for a
# dry run (`GPU_REMOTE_ICD=` picks the ICD file; by default the NVIDIA one when it exists).
# Variants: the splat stage runs with and without block culling (SONARPROJ_GPU_CULL=0), with and
# without its f32 filter (SONARPROJ_GPU_FILTER=0), with workgroups of 32, 128 and 256 threads
# besides 64 (SONARPROJ_GPU_WORKGROUP), and in double-f32 instead of f64
# (SONARPROJ_GPU_PRECISION=df, what GPUs without f64 run); `run`
# takes extra `sonarproj bench` arguments from GPU_REMOTE_BENCH (default
# `--scale 200`), GPU_SCENES for the mask test's scene count, and GPU_REMOTE_STEPS a regular
# expression of the step names to run (all by default), for a lease too short for all of them.
set -euo pipefail
cd "$(dirname "$0")/.."
bundle=.gpu

prepare() {
    rm -rf "$bundle" && mkdir -p "$bundle/bin" "$bundle/debs"
    cargo build --release
    # The GPU test and bench binaries, as cargo names them (hash suffixes included).
    cargo test --release --no-run --message-format=json \
        --test agreement --test masks --test gpu_errors --test cli --test bad_input --test mask \
        --test sweep --test pose_sources --test exact --bench projection --bench masks 2>/dev/null |
        python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["kind"] != ["bin"]:
        print(m["target"]["name"] + ("-bench" if m["target"]["kind"] == ["bench"] else "") + " " + m["executable"])
' | while read -r name exe; do
        strip -o "$bundle/bin/$name" "$exe"
    done
    # The applications' unit tests, for the summaries reduced on the device.
    cargo test --release --no-run --message-format=json -p sonarproj-apps --lib 2>/dev/null |
        python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable"):
        print(m["executable"])
' | while read -r exe; do
        strip -o "$bundle/bin/apps" "$exe"
    done
    strip -o "$bundle/bin/sonarproj" target/release/sonarproj
    # The Vulkan loader and GLVND: the remote machine has the NVIDIA driver and its ICD file, not
    # always libvulkan.so.1, and without GLVND's dispatch libraries the ICD (libGLX_nvidia.so.0)
    # loads but yields no vkCreateInstance ("Found no drivers").
    (cd "$bundle/debs" && apt-get download libvulkan1 libglvnd0 libglx0 libegl1 libgl1 libopengl0 \
        libgles2 >/dev/null 2>&1) ||
        echo "note: could not download the loader packages (apt-get update first?)" >&2
    tar -C "$bundle" -cJf "$bundle/bin.tar.xz" bin && rm -rf "$bundle/bin"
    du -sh "$bundle"
    echo "carry .gpu and run: bash scripts/gpu-remote.sh run"
}

run() {
    # $OUT brings back at most 8 files: the logs travel as one archive beside the summary.
    local out="${OUT:-$bundle/out}" logs="$bundle/logs"
    mkdir -p "$out" && rm -rf "$logs" && mkdir -p "$logs"
    tar -C "$bundle" -xJf "$bundle/bin.tar.xz"
    for f in "$bundle"/debs/*.deb; do [ -e "$f" ] && dpkg -x "$f" /; done
    ldconfig || true
    local nvidia=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    [ -e /usr/share/vulkan/icd.d/nvidia_icd.json ] && nvidia=/usr/share/vulkan/icd.d/nvidia_icd.json
    export VK_DRIVER_FILES="${GPU_REMOTE_ICD-$( [ -e "$nvidia" ] && echo "$nvidia")}"
    [ -n "$VK_DRIVER_FILES" ] || unset VK_DRIVER_FILES
    export WGPU_BACKEND=vulkan NODEVICE_SELECT=1 CI=true
    # The CLI tests find the binary here (assert_cmd reads this variable first).
    export CARGO_BIN_EXE_sonarproj="$PWD/$bundle/bin/sonarproj"
    local bin="$bundle/bin" status=0
    step() {
        local name=$1
        shift
        # GPU_REMOTE_STEPS (an extended regular expression) runs only the steps it matches.
        if [ -n "${GPU_REMOTE_STEPS:-}" ] && ! [[ $name =~ ^(${GPU_REMOTE_STEPS})$ ]]; then
            return 0
        fi
        echo "== $name: $*" | tee -a "$logs/summary.txt"
        local start=$SECONDS
        if "$@" >"$logs/$name.log" 2>&1; then
            echo "   ok ($((SECONDS - start)) s)" | tee -a "$logs/summary.txt"
        else
            echo "   FAILED ($((SECONDS - start)) s): tail of $name.log" | tee -a "$logs/summary.txt"
            tail -20 "$logs/$name.log" | tee -a "$logs/summary.txt"
            status=1
        fi
    }
    (nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv || true) >"$logs/gpu.txt" 2>&1
    step devices "$bin/sonarproj" devices
    step test-agreement "$bin/agreement"
    step test-masks "$bin/masks"
    step test-gpu-errors "$bin/gpu_errors"
    step test-cli "$bin/cli"
    step test-bad-input "$bin/bad_input"
    step test-mask-cli "$bin/mask"
    step test-sweep "$bin/sweep"
    step test-pose-sources "$bin/pose_sources"
    step test-exact "$bin/exact"
    step test-summary-device "$bin/apps" device_tests
    # shellcheck disable=SC2086
    step bench-projection "$bin/sonarproj" bench ${GPU_REMOTE_BENCH:---scale 200} --no-reference
    # shellcheck disable=SC2086
    step bench-projection-nocull env SONARPROJ_GPU_CULL=0 "$bin/sonarproj" bench ${GPU_REMOTE_BENCH:---scale 200} --no-reference
    # shellcheck disable=SC2086
    step bench-projection-nofilter env SONARPROJ_GPU_FILTER=0 "$bin/sonarproj" bench ${GPU_REMOTE_BENCH:---scale 200} --no-reference
    for w in 32 128 256; do
        # shellcheck disable=SC2086
        step "bench-projection-wg$w" env SONARPROJ_GPU_WORKGROUP=$w "$bin/sonarproj" bench ${GPU_REMOTE_BENCH:---scale 200} --no-reference
    done
    # shellcheck disable=SC2086
    step bench-projection-df env SONARPROJ_GPU_PRECISION=df "$bin/sonarproj" bench ${GPU_REMOTE_BENCH:---scale 200} --no-reference
    # shellcheck disable=SC2086
    step bench-projection-df-nofilter env SONARPROJ_GPU_PRECISION=df SONARPROJ_GPU_FILTER=0 "$bin/sonarproj" bench ${GPU_REMOTE_BENCH:---scale 200} --no-reference
    step test-agreement-df env SONARPROJ_GPU_PRECISION=df "$bin/agreement"
    step bench-masks "$bin/sonarproj" bench masks
    step paper-gpu "$bin/sonarproj" paper --backend gpu --out "$bundle/paper-gpu"
    step paper-cpu "$bin/sonarproj" paper --backend cpu-fast --out "$bundle/paper-cpu"
    step criterion-projection "$bin/projection-bench" --bench
    # Sweeps (the sweep issue's targets): 1 M fls→sss poses to Parquet, and as summaries only,
    # on the GPU and on the CPU cores of the same machine.
    local summaries="$bundle/bench-sweep-1m-summary.toml"
    { cat data/bench-sweep-1m.toml
      printf '[summary]\nhistogram = { min = 0, max = 1.2, bins = 120 }\nmarginals = [["roll", "pitch"], "yaw"]\nrows = false\n'
    } >"$summaries"
    for b in gpu cpu-fast; do
        rm -rf "$bundle/sweep-$b" "$bundle/sweep-sum-$b"
        step "sweep-parquet-$b" "$bin/sonarproj" sweep --config data/bench-sweep-1m.toml --out "$bundle/sweep-$b" --backend "$b" --format parquet
        step "sweep-summary-$b" "$bin/sonarproj" sweep --config "$summaries" --out "$bundle/sweep-sum-$b" --backend "$b"
    done
    # The grid decoded on the device against the per-item path, on 10 M poses (1.2 G samples):
    # the projection's samples/s, the host's cost a pose, the sweeps' multiples of it.
    step bench-sweep "$bin/sonarproj" bench sweep --backends gpu,cpu-fast --poses 10000000 --runs 3
    # The same with 1 M poses a projection call instead of the sweep's chunk of 131 072: what the
    # per-call cost is (device time against project time).
    step bench-sweep-block "$bin/sonarproj" bench sweep --backends gpu,cpu-fast --poses 10000000 --runs 3 --block 1048576
    # 10^8 poses with summaries only against their projection (the sweep issue's 1.1x), without
    # the per-item path and the 4.7 GB Parquet sweep.
    step bench-sweep-1e8 "$bin/sonarproj" bench sweep --backends gpu,cpu-fast --poses 100000000 --runs 1 --measures summary
    # Exact arcs against 0.1° sampling, summaries only: the exact stage's speed on the device.
    for sampling in 0.1 exact; do
        step "bench-sweep-step-$sampling" "$bin/sonarproj" bench sweep --backends gpu,cpu-fast --poses 10000000 --runs 3 --measures summary --step "$sampling"
    done
    # Where the device's time goes, per stage (poses, splat, reduce: a pass each when timed), for
    # the splat stage's variants on the same 10 M-pose summaries-only sweep.
    local v
    for v in f64 df wg32 wg128 wg256 nocull nofilter; do
        local vars=()
        case $v in
        df) vars=(SONARPROJ_GPU_PRECISION=df) ;;
        wg*) vars=(SONARPROJ_GPU_WORKGROUP=${v#wg}) ;;
        nocull) vars=(SONARPROJ_GPU_CULL=0) ;;
        nofilter) vars=(SONARPROJ_GPU_FILTER=0) ;;
        esac
        step "bench-stages-$v" env "${vars[@]}" "$bin/sonarproj" bench sweep --backends gpu --poses 10000000 --runs 3 --measures summary
    done
    # mask --stream given 2000 pings of 100 features at once (all waiting): drawn together, two
    # in flight on a GPU; the wall time a ping.
    local pings="$bundle/stream-pings.jsonl" feats="" k
    for k in $(seq 0 99); do feats+="${feats:+, }[$((400 + 5 * k))e-2]"; done
    for k in $(seq 1 2000); do
        printf '{"pose": {"pitch": 5, "yaw": %d, "translation": [0.3, 0.2, -0.1]}, "features": [%s]}\n' $((k % 20)) "$feats"
    done >"$pings"
    for b in gpu cpu-fast; do
        step "stream-$b" bash -c 'start=$(date +%s.%N)
            n=$("$0" mask --from holoocean-sidescan --to holoocean-imaging --backend "$2" --stream --no-runs <"$1" | grep -c "\"features\"")
            awk -v n="$n" -v s="$start" -v e="$(date +%s.%N)" -v b="$2" "BEGIN { printf \"stream: %s %d pings answered, %.3f ms a ping\\n\", b, n, (e - s) * 1000 / n }"' \
            "$bin/sonarproj" "$pings" "$b"
    done
    # The rig advisor's target (10 000 rotations x 1000 features x 121 samples) on both, and
    # the same candidates in its default mode (exact arcs).
    for b in gpu cpu-fast; do
        rm -rf "$bundle/advise-$b" "$bundle/advise-exact-$b"
        step "advise-$b" "$bin/sonarproj" advise --config data/bench-advise.toml --out "$bundle/advise-$b" --backend "$b"
        step "advise-exact-$b" "$bin/sonarproj" advise --config data/bench-advise-exact.toml --out "$bundle/advise-exact-$b" --backend "$b"
    done
    grep -h "advise:" "$logs"/advise-*.log >>"$logs/summary.txt" || true
    grep -h "sweep:" "$logs"/sweep-*.log >>"$logs/summary.txt" || true
    grep -h "stream:" "$logs"/stream-*.log >>"$logs/summary.txt" || true
    grep -hE "^(gpu|cpu-fast) " "$logs"/bench-sweep*.log >>"$logs/summary.txt" || true
    # With the file names: which variant each stage split is.
    grep -E "^gpu |one more timed run" "$logs"/bench-stages-*.log >>"$logs/summary.txt" || true
    grep -h "paper:" "$logs"/paper-*.log >>"$logs/summary.txt" || true
    # With the file names: which variant each row is.
    grep -- "->" "$logs"/bench-projection*.log >>"$logs/summary.txt" || true
    cp "$logs/summary.txt" "$out/summary.txt"
    tar -C "$bundle" -czf "$out/logs.tar.gz" logs
    return $status
}

case "${1:-}" in
prepare) prepare ;;
run) run ;;
*)
    echo "usage: scripts/gpu-remote.sh prepare|run" >&2
    exit 2
    ;;
esac
