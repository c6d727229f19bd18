#!/usr/bin/env bash
# Rebuilds data/demos/captured.mcap from the CMU motion-capture trials it was made from:
# downloads each BVH file (pinned to a commit, checked by MD5) into a cache folder unless it is
# there already, imports the arm-rich span of each with `sgplvm import`, then retargets the
# human's arms onto WALK-MAN, COMAN and CENTAURO with `sgplvm retarget` (blocks of 4 s, every
# fourth block for testing). Run from the repository root:
#
#     bash data/demos/make_captured.sh [BVH_CACHE_DIR]      (default: target/cmu-bvh)
#
# OUT=FILE writes elsewhere; RETARGET_ARGS adds flags to `sgplvm retarget` (e.g.
# "--redundancy canonical", the variant docs/experiment-report-captured.md compares).
#
# Needs curl (or the files already in the cache) and a built sgplvm (cargo builds it).
# The data: CMU Graphics Lab Motion Capture Database, http://mocap.cs.cmu.edu, "created with
# funding from NSF EIA-0196217"; BVH conversions by B. Hahne (cgspeed). See data/demos/README.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
cache=${1:-target/cmu-bvh}
out=${OUT:-data/demos/captured.mcap}
mkdir -p "$cache"
cargo build --release --quiet --bin sgplvm
sgplvm=target/release/sgplvm
# shellcheck source=data/demos/fetch_bvh.sh
source data/demos/fetch_bvh.sh

# trial | URL (a public copy, pinned to a commit) | MD5 | span imported (sgplvm import flags)
trials=(
  "13_26|https://raw.githubusercontent.com/gazebosim/gz-common/f4a6dbd1f30b0a3b0c11b067a4e3596384944d8a/test/data/cmu-13_26.bvh|edc0e3feac9a549dc7e6306effbf95e2|"
  "13_29|https://raw.githubusercontent.com/GuiYi-Xi/monoform-previs-studio/daa54b2f6e78cc69f07102f7d32f6fabe3ac4a54/scripts/assets/CMU_13_29.bvh|7deac987ee2465f6fa8562493ddd88d2|--to 22"
  "13_10|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_10.bvh|3ac62c5fbb057ab43ae2772dfc9177d0|--from 0.5"
  "14_07|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/14/14_07.bvh|63b7f5164569e0e26bde057bdce7d276|--from 0.5"
  "14_08|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/14/14_08.bvh|3e21c434dadcf4350983ec40f4689615|--from 0.5"
)

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
demos=()
for entry in "${trials[@]}"; do
  IFS='|' read -r trial url md5 span <<<"$entry"
  bvh="$cache/$trial.bvh"
  if [ ! -f "$bvh" ] && [ -f "data/capture/cmu-$trial.bvh" ]; then
    cp "data/capture/cmu-$trial.bvh" "$bvh"   # shipped with the repository (data/capture)
  fi
  fetch_bvh "$bvh" "$url" "$md5"
  # shellcheck disable=SC2086
  "$sgplvm" import "$bvh" --out "$work/$trial.mcap" $span
  demos+=(--demos "$work/$trial.mcap")
done
# shellcheck disable=SC2086
"$sgplvm" retarget "${demos[@]}" --robots walkman,coman,centauro --out "$out" ${RETARGET_ARGS:-}
