#!/usr/bin/env bash
# Low-texture matrix: the rooms where points run out and the depth alignment, the
# photometric term and the planes must hold the pose. Renders synthetic low-texture
# rooms (`gfsvo synth --scene low-texture --frames 120`, trajectories slow / fast /
# rotation, seeds 1-8 by default) and runs `gfsvo run --mode inline` on each with one
# ablation column's switches; prints each sequence's ATE RMSE and frames not `tracked`,
# then the mean and how many meet the goal (ATE <= 4 mm, every frame tracked). "lost":
# no ATE (the map never started).
#
#   cargo build --release -p gfsvo
#   tests/bench/low_texture.sh [points|default|planes|depth|all] ["SEED ..."]
#
# SENSOR=NAME renders with `gfsvo synth --sensor NAME` (default kinect-v1, as `gfsvo
# synth`; the README's figures from before the sensors were told apart are `ideal`).
# Sequences are rendered once into target/low-texture/SENSOR/ (WORK=DIR elsewhere); GFSVO=PATH
# runs another binary; delete the folder after changing `gfsvo synth` (it renders only
# what is missing). Not run by CI: about 10 s per sequence on two cores.
#
# EXTRA='TOML' is appended to each run's config (a table other than `[tracking]` and
# `[tracking.depth]`, which the config already has), and the runs go to runs/NAME with
# RUNS=NAME (default: the column). Bare-wall sequences (slow 4, slow 5) turn on small
# changes: compare a change over a few perturbations, e.g.
#   EXTRA=$'[tracking.planes]\nnormal_sigma_deg = 0.99' RUNS=all-0.99 tests/bench/low_texture.sh all
set -euo pipefail

column=${1:-all}
seeds=${2:-"1 2 3 4 5 6 7 8"}
root=$(cd "$(dirname "$0")/../.." && pwd)
gfsvo=${GFSVO:-$root/target/release/gfsvo}
sensor=${SENSOR:-kinect-v1}
work=${WORK:-$root/target/low-texture/$sensor}
if [ ! -x "$gfsvo" ]; then
    echo "no $gfsvo: run 'cargo build --release -p gfsvo' first (or set GFSVO)" >&2
    exit 1
fi
case $column in
    points) switches=$'[tracking]\nuse_lines = false' ;;
    default) switches='' ;;
    planes) switches=$'[tracking]\nuse_planes = true' ;;
    depth) switches=$'[tracking]\nuse_depth_alignment = true' ;;
    all) switches=$'[tracking]\nuse_depth_alignment = true\nuse_planes = true' ;;
    *)
        echo "unknown column '$column': points, default, planes, depth or all" >&2
        exit 2
        ;;
esac

for traj in slow fast rotation; do
    for seed in $seeds; do
        name=${traj}_$seed
        sequence=$work/$name
        if [ ! -f "$sequence/groundtruth.txt" ]; then
            "$gfsvo" synth --scene low-texture --traj "$traj" --frames 120 --seed "$seed" \
                --sensor "$sensor" \
                --out "$sequence" --log warn >/dev/null
        fi
        out=$work/runs/${RUNS:-$column}/$name
        mkdir -p "$out"
        { cat "$sequence/synthetic.toml"; printf '\n%s\n\n%s\n' "$switches" "${EXTRA:-}"; } >"$out/config.toml"
        "$gfsvo" run "$sequence" --mode inline --config "$out/config.toml" --out "$out" \
            --log warn >"$out/log.txt" 2>&1 || true
        ate=$(grep -m1 -o 'ATE RMSE [0-9.]*' "$out/log.txt" | awk '{print $3 * 1000}' || true)
        untracked=$(grep -v '^#' "$out/status.txt" 2>/dev/null | awk '$3 != "tracked"' | wc -l)
        echo "$name ${ate:-lost} $untracked"
    done
done | awk -v column="$column" '
    { printf "%-12s %8s mm  %3d not tracked\n", $1, $2, $3 }
    $2 != "lost" { sum += $2; n++; if ($2 <= 4 && $3 == 0) ok++ }
    END { printf "%s: mean ATE %.2f mm over %d sequences; %d of %d within 4 mm with every frame tracked\n", column, (n ? sum / n : 0), n, ok, NR }'
