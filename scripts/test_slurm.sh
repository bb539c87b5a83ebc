#!/usr/bin/env bash
# Runs the guide's Slurm recipe (docs/sweeps.md) on a real single-node Slurm cluster started here by hand (munge,
# slurmctld, slurmd from Debian's packages; no systemd), and checks that the merged sweep is byte
# for byte what one run writes. Everything lives in a temporary directory with its own munge
# socket and ports, and is stopped and removed on exit whatever happens.
# Usage: scripts/test_slurm.sh [path/to/sonarproj]
set -euo pipefail
cd "$(dirname "$0")/.."
bin="$(realpath "${1:-target/release/sonarproj}")"
[ -x "$bin" ] || { echo "test_slurm: no binary at $bin (build it first)" >&2; exit 1; }

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null \
    || ! command -v sbatch >/dev/null; then
    echo "installing slurmctld slurmd slurm-client munge (apt)" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge >/dev/null
fi

work="$(mktemp -d /tmp/sonarproj-slurm.XXXXXX)"
chmod 755 "$work"
pids=()
stop() {
    local rc=$?
    for pid in "${pids[@]}"; do $sudo kill "$pid" 2>/dev/null || true; done
    sleep 1
    for pid in "${pids[@]}"; do $sudo kill -9 "$pid" 2>/dev/null || true; done
    if [ "$rc" -ne 0 ]; then
        for log in "$work"/*.log; do
            [ -f "$log" ] && { echo "--- $log" >&2; tail -n 30 "$log" >&2; }
        done
    fi
    $sudo rm -rf "$work"
    exit "$rc"
}
trap stop EXIT

# Two free TCP ports on this host for slurmctld and slurmd.
read -r ctld_port slurmd_port < <(python3 - <<'PY'
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in socks))
PY
)
node="$(hostname -s)"
user="$(id -un)"

# munge with its own key and socket, so a system munged (if any) is left alone.
dd if=/dev/urandom of="$work/munge.key" bs=1024 count=1 status=none
chmod 600 "$work/munge.key"
mkdir -m 700 "$work/munge"
$sudo munged --force --key-file="$work/munge.key" --socket="$work/munge/munge.sock" \
    --pid-file="$work/munge/munged.pid" --log-file="$work/munged.log" \
    --seed-file="$work/munge/munged.seed"
for _ in $(seq 50); do [ -s "$work/munge/munged.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$work/munge/munged.pid")")
chmod 755 "$work/munge"

mkdir -p "$work/state" "$work/spool"
cat >"$work/slurm.conf" <<CONF
ClusterName=sonarproj-test
SlurmctldHost=$node(127.0.0.1)
SlurmUser=$user
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge/munge.sock
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SlurmdTimeout=60
NodeName=$node NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
$sudo env SLURM_CONF="$SLURM_CONF" slurmctld -i
$sudo env SLURM_CONF="$SLURM_CONF" slurmd
for _ in $(seq 100); do [ -s "$work/slurmctld.pid" ] && [ -s "$work/slurmd.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$work/slurmctld.pid")" "$(cat "$work/slurmd.pid")")
up=""
for _ in $(seq 120); do
    if sinfo -h -N -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then up=1; break; fi
    sleep 0.5
done
[ -n "$up" ] || { echo "test_slurm: the node never came up: $(sinfo -N 2>&1)" >&2; exit 1; }
echo "test_slurm: Slurm $(sinfo -V | cut -d' ' -f2) up on $node" >&2

# The sweep: 5 shards on an array of 2 tasks (more shards than array tasks), then the merge as a
# job that waits for the array, as docs/sweeps.md says.
cp data/example-sweep.toml "$work/sweep.toml"
out="$work/out"
cd "$work"
export SONARPROJ="$bin"
jobid="$(sbatch --parsable --array=1-2 "$OLDPWD/examples/slurm/sweep-array.sh" sweep.toml out 5 --backend cpu-fast)"
# --kill-on-invalid-dep: a failed shard cancels the merge (else it would wait forever).
if ! timeout 600 sbatch --wait --quiet --dependency="afterok:$jobid" --kill-on-invalid-dep=yes \
    --output=merge.log --wrap "\"$bin\" merge out"; then
    echo "test_slurm: the merge job did not succeed; the array's jobs:" >&2
    squeue -a 2>&1 >&2 || true
    tail -n 20 sonarproj-sweep-*.out merge.log >&2 2>/dev/null || true
    exit 1
fi
for k in 1 2 3 4 5; do
    [ -f "out/shard-$k-of-5.csv" ] || { echo "test_slurm: shard $k of 5 missing" >&2; cat sonarproj-sweep-*.out >&2; exit 1; }
done
"$bin" sweep --config sweep.toml --out single --backend cpu-fast >/dev/null 2>&1
for f in sweep.csv sweep.json sweep-span.png; do
    cmp "single/$f" "out/$f" || { echo "test_slurm: out/$f differs from one run's" >&2; exit 1; }
done
echo "test_slurm: passed (5 shards on a 2-task array, merged by a dependent job, byte for byte one run)" >&2
