#!/bin/bash
# End-to-end test of examples/slurm/ on a single-node Slurm cluster started here, on localhost:
#   1. installs Debian's slurm-wlm and munge if missing (apt-get; run as root);
#   2. starts munged, slurmctld and slurmd in the background with a slurm.conf and munge key in
#      a temporary directory (no systemd needed; everything is stopped and removed on exit);
#   3. builds raylink in release mode;
#   4. submits examples/slurm/submit.sh (precompute the irradiance cache, a 4-task render
#      array, a merge) on a small scene and waits for it (timeout: $SLURM_TEST_TIMEOUT s,
#      default 900);
#   5. renders the same image locally in one piece and checks that the merged image equals it
#      bit for bit (idiff with zero tolerance).
# Prints the wall times. Exit status 0 only if everything passed.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
start_all=$(date +%s%N)
timeout=${SLURM_TEST_TIMEOUT:-900}
say() { echo "test-slurm: $*"; }
fail() {
    echo "test-slurm: FAILED: $*" >&2
    exit 1
}
# Seconds since a `date +%s%N` time, to a tenth.
elapsed() {
    local ds=$((($(date +%s%N) - $1) / 100000000))
    echo "$((ds / 10)).$((ds % 10))"
}

if [[ $(id -u) -ne 0 ]]; then
    fail "run as root (it installs packages and starts the Slurm daemons)"
fi
need=()
for cmd in slurmctld:slurm-wlm slurmd:slurm-wlm sbatch:slurm-wlm munged:munge \
    idiff:openimageio-tools; do
    command -v "${cmd%%:*}" >/dev/null || need+=("${cmd#*:}")
done
if [[ ${#need[@]} -gt 0 ]]; then
    mapfile -t need < <(printf '%s\n' "${need[@]}" | sort -u)
    say "installing ${need[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # policy-rc.d: the packages must not try to start their services (no init system here).
    rcd=/usr/sbin/policy-rc.d
    own_rcd=0
    if [[ ! -e $rcd ]]; then
        printf '#!/bin/sh\nexit 101\n' >"$rcd" && chmod +x "$rcd" && own_rcd=1
    fi
    apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
    [[ $own_rcd -eq 1 ]] && rm -f "$rcd"
fi

work=$(mktemp -d /tmp/raylink-slurm.XXXXXX)
chmod 755 "$work"
pids=()
cleanup() {
    local status=$?
    for pid in "${pids[@]}"; do
        kill "$pid" 2>/dev/null || true
    done
    for pid in "${pids[@]}"; do
        wait "$pid" 2>/dev/null || true
    done
    if [[ $status -ne 0 && -d $work ]]; then
        for log in "$work"/*.log "$work"/out/*.log; do
            [[ -f $log ]] && { echo "--- $log"; tail -n 20 "$log"; }
        done
    fi
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# munge: our own key and socket, so that a munged already running is left alone.
mkdir -p "$work/munge"
chmod 711 "$work/munge"
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
socket=$work/munge/munge.socket
munged --foreground --force --key-file="$work/munge/munge.key" --socket="$socket" \
    --pid-file="$work/munge/munged.pid" --log-file="$work/munge.log" \
    --seed-file="$work/munge/munge.seed" 2>"$work/munged.out" &
pids+=($!)

host=$(hostname -s)
cpus=$(nproc)
mkdir -p "$work/state" "$work/spool" "$work/out"
conf=$work/slurm.conf
cat >"$conf" <<EOF
ClusterName=raylinktest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
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
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
DependencyParameters=kill_invalid_depend
ReturnToService=2
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf
for _ in $(seq 50); do
    [[ -S $socket ]] && break
    sleep 0.1
done
[[ -S $socket ]] || fail "munged did not start (see $work/munge.log)"
slurmctld -D -i -f "$conf" >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N "$host" -f "$conf" >"$work/slurmd.out" 2>&1 &
pids+=($!)

say "building raylink (release)"
cargo build --release --quiet --manifest-path "$repo/Cargo.toml"
target=${CARGO_TARGET_DIR:-$repo/target}
raylink=$target/release/raylink
[[ -x $raylink ]] || fail "no binary at $raylink"

ready=0
for _ in $(seq 120); do
    if sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then
        ready=1
        break
    fi
    sleep 0.5
done
[[ $ready -eq 1 ]] || fail "the Slurm node did not become idle (see $work/slurmctld.log, $work/slurmd.log)"
say "Slurm is up: $(sinfo -h -o '%P %D %c %T')"

scene=$repo/scenes/cornell-box.toml
tiles=4
opts=(--integrator irradiance-cache --width 96 --height 72 --spp 4 --ab 2 --ic-samples 128 --seed 7)
say "submitting: $tiles tiles of $scene ${opts[*]}"
start_jobs=$(date +%s%N)
RAYLINK=$raylink "$repo/examples/slurm/submit.sh" "$scene" "$work/out" "$tiles" "${opts[@]}" \
    | tee "$work/jobs.txt"
deadline=$(($(date +%s) + timeout))
while [[ -n $(squeue -h -o %i 2>/dev/null) ]]; do
    if [[ $(date +%s) -gt $deadline ]]; then
        squeue
        fail "the jobs did not finish within $timeout s"
    fi
    sleep 1
done
jobs_seconds=$(elapsed "$start_jobs")
for id in $(grep -o 'job [0-9]*' "$work/jobs.txt" | awk '{print $2}'); do
    state=$(scontrol show job "$id" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | sort -u | tr '\n' ' ')
    say "job $id: $state"
    [[ $state == "JobState=COMPLETED " ]] || fail "job $id ended $state"
done
merged=$work/out/image.exr
[[ -f $merged ]] || fail "no merged image $merged"

say "rendering the same image locally in one piece"
"$raylink" render "$scene" "${opts[@]}" --quiet -o "$work/local.exr"
# Zero tolerance: any differing value fails.
if ! idiff -q -fail 0 -warn 0 "$work/local.exr" "$merged"; then
    idiff -fail 0 -warn 0 "$work/local.exr" "$merged" || true
    fail "the merged image differs from the local render"
fi
oiiotool --info -v "$merged" | grep -E 'raylink:(merged_parts|settings)'
say "PASS: the merged image of $tiles Slurm tasks equals the local render bit for bit"
say "Slurm jobs (submit to merged image): $jobs_seconds s; whole script: $(elapsed "$start_all") s"
