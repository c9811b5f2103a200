#!/usr/bin/env bash
# Honest-uncertainty matrix: each sequence's ATE, frames per status, the NEES of the
# published covariances (mean, share beyond the 99.9 % bound 22.46) and the median
# frame-to-frame translation error, from `gfsvo run --mode inline --json` (its `nees`
# field, as `gfsvo eval --consistency`). Sequences: the low-texture rooms (`gfsvo synth
# --scene low-texture --frames 120`, trajectories slow / rotation / fast, seeds 1-4 by
# default) rendered with SENSOR (default kinect-v1), and the real sequences of
# ../shared/data (TUM fr1_rpy, 7-Scenes red kitchen; skipped when absent).
#
#   cargo build --release -p gfsvo
#   tests/bench/consistency.sh [default|all] ["SEED ..."]
#
# `all` turns on `[tracking] use_depth_alignment = true, use_planes = true`. Sequences
# are rendered once into target/consistency/<sensor>/ (WORK=DIR elsewhere); runs go to
# target/consistency/runs/<sensor>-<column>/. Not run by CI: 20-40 s per sequence on
# two cores. Prints one row per sequence:
#   name ate_mm tracked degraded relocalised predicted nees_mean beyond_% f2f_mm sigma_mm
set -euo pipefail

column=${1:-default}
seeds=${2:-"1 2 3 4"}
sensor=${SENSOR:-kinect-v1}
root=$(cd "$(dirname "$0")/../.." && pwd)
gfsvo=${GFSVO:-$root/target/release/gfsvo}
work=${WORK:-$root/target/consistency}
data=${DATA:-$root/../shared/data}
if [ ! -x "$gfsvo" ]; then
    echo "no $gfsvo: run 'cargo build --release -p gfsvo' first (or set GFSVO)" >&2
    exit 1
fi
case $column in
    default) switches='' ;;
    all) switches=$'[tracking]\nuse_depth_alignment = true\nuse_planes = true' ;;
    *)
        echo "unknown column '$column': default or all" >&2
        exit 2
        ;;
esac

# run NAME SEQUENCE BASE_CONFIG: one inline run, one row.
run() {
    local name=$1 sequence=$2 base=$3
    local out=$work/runs/$sensor-$column/$name
    mkdir -p "$out"
    { cat "$base"; printf '\n%s\n' "$switches"; } >"$out/config.toml"
    if ! "$gfsvo" run "$sequence" --mode inline --config "$out/config.toml" --out "$out" \
        --json --log warn >"$out/summary.json" 2>"$out/log.txt"; then
        if grep -q 'was tracked' "$out/log.txt"; then
            # Every frame predicted: the map never started.
            printf '%s\tlost\t0\t0\t0\t%s\t-\t-\t-\t-\n' "$name" \
                "$(grep -vc '^#' "$out/status.txt")"
        else
            echo "$name failed (see $out/log.txt)"
        fi
        return
    fi
    jq -r --arg name "$name" '[$name,
        (if .ate_rmse_m then (.ate_rmse_m * 1000 | . * 100 | round / 100) else "lost" end),
        (.status.tracked // 0), (.status.degraded // 0), (.status.relocalised // 0),
        (.status.predicted // 0),
        (if .nees.mean then (.nees.mean | . * 10 | round / 10) else "-" end),
        (if .nees.beyond_999 then (.nees.beyond_999 * 1000 | round / 10) else "-" end),
        (if .nees.f2f_trans_median_m then (.nees.f2f_trans_median_m * 1e4 | round / 10) else "-" end),
        (if .nees.reported_sigma_median_m then (.nees.reported_sigma_median_m * 1e4 | round / 10) else "-" end)
        ] | @tsv' "$out/summary.json"
}

for traj in slow rotation fast; do
    for seed in $seeds; do
        name=${traj}_$seed
        sequence=$work/$sensor/$name
        if [ ! -f "$sequence/groundtruth.txt" ]; then
            "$gfsvo" synth --scene low-texture --traj "$traj" --frames 120 --seed "$seed" \
                --sensor "$sensor" --out "$sequence" --log warn >/dev/null
        fi
        run "$name" "$sequence" "$sequence/synthetic.toml"
    done
done
for real in tum_fr1_rpy_head300:tum1 7scenes_redkitchen_head300:7scenes; do
    folder=${real%%:*}
    if [ -d "$data/$folder" ]; then
        run "$folder" "$data/$folder" "$root/configs/${real##*:}.toml"
    else
        echo "$folder: skipped, no $data/$folder"
    fi
done
