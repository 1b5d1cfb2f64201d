#!/bin/bash
# Submits the three jobs of a tiled raylink render with their dependencies:
#   precompute  ->  render array (tasks 0..N-1, after the precompute succeeded)
#               ->  merge (after every render task succeeded)
# Usage: submit.sh SCENE OUT_DIR TILES [RAYLINK_OPTS...]
# Environment: RAYLINK (the binary, default: raylink on PATH), RAYLINK_PRECOMPUTE
# (cache, network or none; default: cache if the options select the irradiance-cache
# integrator, network for the network integrator, else none), RAYLINK_IMAGE (default
# image.exr), SBATCH_ARGS (extra sbatch arguments for every job, e.g. "--partition=render
# --cpus-per-task=8"). OUT_DIR must be on a filesystem every node sees; the precomputed
# file is written there (do not pass --cache-file or --network-file). Prints the job ids.
set -euo pipefail
if [[ $# -lt 3 ]]; then
    sed -n '2,11p' "$0" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
scene=$(realpath "$1")
out=$2
tiles=$3
shift 3
mkdir -p "$out"
out=$(realpath "$out")
opts="$*"
if [[ -z "${RAYLINK_PRECOMPUTE:-}" ]]; then
    case " $opts " in
    *" --integrator irradiance-cache "* | *" --integrator=irradiance-cache "*)
        RAYLINK_PRECOMPUTE=cache ;;
    *" --integrator network "* | *" --integrator=network "*) RAYLINK_PRECOMPUTE=network ;;
    *) RAYLINK_PRECOMPUTE=none ;;
    esac
fi
case "$RAYLINK_PRECOMPUTE" in
cache) file=precomputed.ic ;;
network) file=precomputed.net ;;
none) file= ;;
*) echo "submit.sh: RAYLINK_PRECOMPUTE must be cache, network or none" >&2; exit 2 ;;
esac
# Absolute, since the jobs run in OUT_DIR (and on other nodes).
RAYLINK=$(command -v "${RAYLINK:-raylink}") || {
    echo "submit.sh: no raylink binary: install it or set RAYLINK" >&2
    exit 2
}
export RAYLINK=$(realpath "$RAYLINK")
export RAYLINK_SCENE=$scene RAYLINK_OUT=$out RAYLINK_TILES=$tiles RAYLINK_OPTS=$opts
export RAYLINK_PRECOMPUTE RAYLINK_PRECOMPUTE_FILE=$file
export RAYLINK_IMAGE=${RAYLINK_IMAGE:-image.exr}
# shellcheck disable=SC2206 # SBATCH_ARGS holds several arguments
common=(--parsable --export=ALL --chdir="$out" ${SBATCH_ARGS:-})
after=()
if [[ $RAYLINK_PRECOMPUTE != none ]]; then
    pre=$(sbatch "${common[@]}" --output="$out/precompute.log" "$here/precompute.sbatch")
    echo "precompute job $pre"
    after=(--dependency="afterok:$pre")
fi
array=$(sbatch "${common[@]}" "${after[@]}" --array="0-$((tiles - 1))" \
    --output="$out/render_%a.log" "$here/render.sbatch")
echo "render array job $array (tasks 0-$((tiles - 1)))"
merge=$(sbatch "${common[@]}" --dependency="afterok:$array" --output="$out/merge.log" \
    "$here/merge.sbatch")
echo "merge job $merge"
