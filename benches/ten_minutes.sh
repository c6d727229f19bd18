#!/usr/bin/env bash
# Times docs/ten-minutes.md from `git clone`: clone, `cargo install --path .` (the release build),
# then the guide's steps (import, robot, retarget, train, and the live block in a loopback-only
# network namespace). Usage: bash benches/ten_minutes.sh [REPOSITORY]   (default: this clone).
# Crates already in cargo's download cache are not downloaded again: say so with the figure.
set -euo pipefail
repo=${1:-$(cd "$(dirname "$0")/.." && pwd)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
start=$(date +%s.%N)
git clone -q "$repo" "$work/clone"
cd "$work/clone"
cargo install --path . --root "$work/bin" --quiet --locked
built=$(date +%s.%N)
export PATH=$work/bin/bin:$PATH
sgplvm import data/capture/cmu-13_26.bvh --out me.mcap > /dev/null
sgplvm robot data/urdf/published/g1_29dof.urdf > /dev/null
sgplvm retarget --demos me.mcap --urdf data/urdf/published/g1_29dof.urdf --robot g1 --out g1-demos.mcap > /dev/null 2>&1
sgplvm train --data g1-demos.mcap --robot g1 --parts arms --out g1.sgp > /dev/null 2>&1
flag=-n; unshare -n true 2>/dev/null || flag=-rn
unshare "$flag" bash -c 'ip link set lo up && ip link set lo multicast on
sgplvm teleop --model g1.sgp --robot g1 --urdf g1=data/urdf/published/g1_29dof.urdf --input mvn:127.0.0.1:9763 --foxglove --max-frames 300 --json > g1-live.json 2>/dev/null &
sleep 1
sgplvm replay --bvh data/capture/cmu-13_26.bvh --as mvn --to 127.0.0.1:9763 --max-messages 400 2>/dev/null
wait $!'
end=$(date +%s.%N)
python3 -c "import json; s=json.load(open('g1-live.json')); print('teleop: frames', s['frames'], 'latency', s['latency'])"
python3 -c "print(f'clone + build {$built - $start:.0f} s, the steps {$end - $built:.1f} s, in all {$end - $start:.0f} s')"
