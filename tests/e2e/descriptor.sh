# What a technique's descriptor declares, end to end: `list techniques` prints its counters; a run
# records the value an automatic parameter resolved to (directional's blur_radius: -1, reported as
# the counter of the same name) in cell.json's params_resolved beside the schema's params; and the
# config's `metrics` is what is scored and written (metrics: [flip]: no SSIM or PSNR column, mean or
# summary value; mae scored with its floor when named). Cells are tiny: seconds.
source "$(dirname "$0")/lib.bash"

expect_exit 0 "list techniques" -- "$PB" list techniques
expect_match "tiled's counters are listed with kind and unit" "^  list_overflows +work +entries +list entries dropped" "$OUT"
expect_match "directional declares the counter of its automatic blur_radius" "^  blur_radius +size +pixels" "$OUT"

cfg="$WORK/d.yaml"
cat > "$cfg" <<YAML
name: d
resolution: [48, 27]
frames: {warmup: 0, count: 1, metrics_every: 1}
scenes: [cornell-box]
reference: {samples: 4, cache_dir: $WORK/cache}
metrics: [flip]
techniques:
  - technique: direct
    params: {shadow_map_size: 64}
  - technique: directional
    params: {photons: 2000, shadow_map_size: 64}
YAML
expect_exit 0 "run with metrics: [flip]" -- "$PB" run "$cfg" --out "$WORK/run"
direct=$(ls -d "$WORK"/run/cells/cornell-box__direct__*)
directional=$(ls -d "$WORK"/run/cells/cornell-box__directional__*)
expect_match "directional: params keeps -1, params_resolved the taps it used (half a 32-pixel node)" '^-1 16 64$' \
  "$(/usr/bin/python3 -c "import json,sys; c=json.load(open(sys.argv[1])); print(c['params']['blur_radius'], c['params_resolved']['blur_radius'], c['params_resolved']['shadow_map_size'])" "$directional/cell.json")"
expect_match "metrics.csv has FLIP and its floor, no SSIM or PSNR" '^frame,path_class,reference,flip,flip_floor,flicker,flicker_floor$' \
  "$(head -1 "$direct/metrics.csv")"
expect_match "cell.json's means hold no SSIM or PSNR" '^False False True$' \
  "$(/usr/bin/python3 -c "import json,sys; m=json.load(open(sys.argv[1]))['metrics']['combined']; print('ssim' in m, 'psnr_floor' in m, 'flip' in m)" "$direct/cell.json")"
expect_match "summary.csv leaves ssim_mean and psnr_mean empty, flip_mean not" '^ok  ok$' \
  "$(/usr/bin/python3 -c "import csv,sys; r=[r for r in csv.DictReader(open(sys.argv[1])) if r['technique'] == 'direct'][0]; print('ok' if r['flip_mean'] else 'no flip', r['ssim_mean'] + r['psnr_mean'], 'ok')" "$WORK/run/summary.csv")"

sed -i 's/^metrics: \[flip\]$/metrics: [mae]/' "$cfg"
expect_exit 0 "run with metrics: [mae]" -- "$PB" run "$cfg" --out "$WORK/mae"
expect_match "mae is scored, with its floor" '^frame,path_class,reference,mae,mae_floor,flicker,flicker_floor$' \
  "$(head -1 "$(ls -d "$WORK"/mae/cells/cornell-box__direct__*)/metrics.csv")"
finish
