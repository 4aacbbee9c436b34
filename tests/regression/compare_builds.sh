#!/usr/bin/env bash
# Renders tests/regression/images.yaml with two builds and compares every frame of every cell:
#   tests/regression/compare_builds.sh BEFORE_DIR [AFTER_DIR]
# BEFORE_DIR / AFTER_DIR hold a build's photonbench, plugins/ and libphotonbench*.so (AFTER_DIR:
# build/). Prints per cell the largest relative pixel difference before/after, beside the before
# build's own run-to-run difference (techniques that accumulate with float atomics on lavapipe are
# not bit-reproducible from one run to the next, by float rounding: under 1e-6 relative), and exits
# 1 when a cell differs by more than 1e-6 relative.
set -euo pipefail
cd "$(dirname "$0")/../.."
before=$1
after=${2:-build}
work=$(mktemp -d)
render() {  # render NAME BUILD_DIR
  echo "compare_builds: rendering $1 with $2"
  LD_LIBRARY_PATH=$(realpath "$2") "$2/photonbench" run tests/regression/images.yaml \
    --out "$work/$1" --set reference.cache_dir="$work/reference-cache" > "$work/$1.log" 2>&1 ||
    { tail -20 "$work/$1.log"; exit 1; }
}
render before "$before"
render again "$before"
render after "$after"
largest() {  # largest CELL SIDE: the largest relative difference of CELL's frames (before vs
  # SIDE), in parts per million of the pixel's value (oiiotool: |a - b| / |a| over every channel)
  local worst=0 ppm f
  for f in "$work"/before/cells/"$1"/images/frame_*.exr; do
    ppm=$(oiiotool "$f" "$work/$2/cells/$1/images/$(basename "$f")" --absdiff "$f" --abs \
      --maxc 1e-30 --div --mulc 1e6 --printstats 2>&1 | sed -n 's/.*Stats Max: *//p' |
      tr ' ' '\n' | grep -E '^[0-9.e+-]+$' | sort -g | tail -1)
    worst=$(python3 -c "print(max(float('$worst'), float('${ppm:-inf}')))")
  done
  echo "$worst"
}
status=0
printf '%-46s %18s %18s\n' cell "run-to-run (ppm)" "before/after (ppm)"
for cell_dir in "$work"/before/cells/*/; do
  cell=$(basename "$cell_dir")
  noise=$(largest "$cell" again)
  change=$(largest "$cell" after)
  verdict=$(python3 -c "c = float('$change'); print('bit-identical' if c == 0 else \
'within 1e-6 relative' if c <= 1 else 'DIFFERENT')")
  [[ $verdict == DIFFERENT ]] && status=1
  printf '%-46s %18s %18s  %s\n' "$cell" "$noise" "$change" "$verdict"
done
echo "compare_builds: $( ((status)) && echo 'some cells changed' || echo 'every cell bit-identical or within 1e-6 relative')"
exit $status
