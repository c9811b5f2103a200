#!/usr/bin/env bash
# Runs the shell blocks of README.md, so that every command a user copies from it works
# with today's CLI. Each ```sh block runs as one bash script (set -euo pipefail) in a
# scratch folder that links the repository's target/ and configs/ (and ../shared, when
# present), so outputs (out/, rendered sequences, bags) land there and the repository
# stays clean; `cargo` in a block runs in the repository. The check fails when a command
# of a block that runs fails.
#
# Which blocks run (the markers, decided from the block's text):
#   - `path/to/`                        skipped: it needs the reader's own dataset;
#   - `ros2 launch` or `gfsvo ros2`     skipped: it needs a live ROS 2 camera;
#   - `../shared/data`                  runs when ../shared/data is beside the repository
#                                       (the TUM / 7-Scenes heads), else skipped;
#   - a line `<!-- readme-check: skip: REASON -->` right before the block skips it;
#   - every other block runs.
# `cargo test --release --workspace` in a block is not run again here: .ci/run runs that
# exact command just before this check (READMECHECK_CARGO_TEST=1 runs it anyway).
#
#   cargo build --release --workspace --bins   # the check reuses the release build
#   bash tests/readme_commands.sh
#
# Measured on the 2-core development machine at load average 10 (other builds running):
# 72 s wall, 24 s of CPU, most of it four `gfsvo run`s and a 60-frame render; the first
# run on a machine also renders the built-in sequence into ~/.cache/gfsvo (about 25 s).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
readme=$root/README.md
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
mkdir "$scratch/repo"
ln -s "$root/target" "$root/configs" "$scratch/repo/"
if [ -d "$root/../shared" ]; then
    ln -s "$(cd "$root/../shared" && pwd)" "$scratch/shared"
fi

# The blocks, one file each, with the skip marker of the line before each.
python3 - "$readme" "$scratch" <<'EOF'
import re, sys
text = open(sys.argv[1]).read().split('\n')
n, marker, block = 0, None, None
for line in text:
    if block is None:
        m = re.match(r'<!-- readme-check: skip: (.*) -->', line)
        if m:
            marker = m.group(1)
        elif line.strip() == '```sh':
            block = []
        elif line.strip():
            marker = None
    elif line.strip() == '```':
        n += 1
        with open(f'{sys.argv[2]}/block{n:02d}.sh', 'w') as f:
            f.write('\n'.join(block) + '\n')
        if marker:
            open(f'{sys.argv[2]}/block{n:02d}.skip', 'w').write(marker)
        block, marker = None, None
    else:
        block.append(line)
EOF

cargo_in_repo='cargo() {
    if [ "${1:-}" = test ] && [ -z "${READMECHECK_CARGO_TEST:-}" ]; then
        echo "    (cargo test: run by .ci/run just before this check; not run again)"
        return 0
    fi
    (cd "$ROOT" && command cargo "$@")
}'

ran=0 skipped=0 failed=0
for block in "$scratch"/block*.sh; do
    name=$(basename "$block" .sh)
    first=$(grep -m1 -v '^\s*#' "$block" | cut -c1-70)
    reason=
    if [ -f "$scratch/$name.skip" ]; then
        reason=$(cat "$scratch/$name.skip")
    elif grep -q 'path/to/' "$block"; then
        reason="needs your own dataset (path/to/)"
    elif grep -qE 'ros2 launch|gfsvo ros2' "$block"; then
        reason="needs a live ROS 2 camera"
    elif grep -q '\.\./shared/data' "$block" && [ ! -d "$root/../shared/data" ]; then
        reason="../shared/data is absent"
    fi
    if [ -n "$reason" ]; then
        echo "readme $name: skipped: $reason: $first"
        skipped=$((skipped + 1))
        continue
    fi
    echo "readme $name: running: $first"
    start=$(date +%s)
    if (cd "$scratch/repo" && ROOT="$root" bash -c "set -euo pipefail
$cargo_in_repo
$(cat "$block")") >"$scratch/$name.log" 2>&1; then
        echo "readme $name: ok ($(($(date +%s) - start)) s)"
        ran=$((ran + 1))
    else
        echo "readme $name: FAILED; its output:" >&2
        tail -n 30 "$scratch/$name.log" >&2
        failed=$((failed + 1))
    fi
done
echo "readme commands: $ran blocks ran, $skipped skipped, $failed failed"
[ "$failed" -eq 0 ]
