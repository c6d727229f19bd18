#!/usr/bin/env bash
# The suit, live, at the suit's rate: an Xsens MVN stream at 240 frames a second (the shipped CMU
# capture replayed as MVN type-02 datagrams at 6x its 40 Hz) into one `sgplvm teleop` node
# driving WALK-MAN, COMAN and CENTAURO from one multi-robot model, each frame fitted as `import`
# fits it. Prints the node's receive -> every command published times (p50, p99, max) and how
# many frames it answered. Runs in a loopback-only network namespace (root or unprivileged user
# namespaces), as the tests do. Usage, from the repository root:
#
#     bash benches/mvn_latency.sh [FRAMES]        (default 2400: 10 s of stream)
set -euo pipefail
cd "$(dirname "$0")/.."
frames=${1:-2400}
cargo build --release --quiet --bin sgplvm
sgplvm=$PWD/target/release/sgplvm
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$sgplvm" train --robot walkman --robot coman --robot centauro --out "$work/multi.sgp" 2>/dev/null
flag=-n
unshare -n true 2>/dev/null || flag=-rn
unshare "$flag" bash -c "
  set -e
  ip link set lo up && ip link set lo multicast on
  '$sgplvm' teleop --model '$work/multi.sgp' --robot walkman --robot coman --robot centauro \
    --input mvn:127.0.0.1:9763 --max-frames $frames --json > '$work/summary.json' 2>/dev/null &
  sleep 1
  '$sgplvm' replay --bvh data/capture/cmu-13_26.bvh --as mvn --to 127.0.0.1:9763 --rate 6 --loop \
    --max-messages $((frames + 200)) 2>/dev/null
  wait \$!
"
python3 - "$work/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
lat, mvn = s["latency"], s["mvn"]
print(f"MVN 240 Hz, 3 robots, fit included: {lat['frames']} frames answered of {mvn['frames']} received "
      f"({s['superseded']} superseded); receive -> published p50 {lat['p50_us']:.0f} us, "
      f"p99 {lat['p99_us']:.0f} us, max {lat['max_us']:.0f} us; fit worst {1e3 * mvn['worst_m']:.4f} mm")
PY
