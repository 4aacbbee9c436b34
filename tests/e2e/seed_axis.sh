# The seed axis end to end: `run --seeds 2` runs every cell twice with consecutive seeds, the photon
# technique's images differ between its seeds and the deterministic one's do not, metrics.csv has
# the flicker of every metric frame after the first, and the run writes each seed group's mean and
# variance images with the Z-test against the reference.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/seeds.yaml"
cat > "$cfg" <<YAML
name: seeds
resolution: [48, 27]
frames: {warmup: 0, count: 3, metrics_every: 1}
seed: 5
scenes: [cornell-box]
reference: {samples: 4, cache_dir: $WORK/cache}
techniques:
  - technique: direct
    params: {shadow_map_size: 64}
  - technique: tiled
    params: {photons: 2000, shadow_map_size: 64}
YAML
run="$WORK/run"
expect_exit 0 "run --seeds 2" -- "$PB" run "$cfg" --out "$run" --seeds 2
cells=$(cd "$run/cells" && ls -d *__seed* | sort | tr '\n' ' ')
expect_match "four cells, seeds 5 and 6" '^cornell-box__direct__[0-9a-f]{8}__seed5 cornell-box__direct__[0-9a-f]{8}__seed6 cornell-box__tiled__[0-9a-f]{8}__seed5 cornell-box__tiled__[0-9a-f]{8}__seed6 $' "$cells"
for technique in direct tiled; do
  a=$(ls -d "$run"/cells/cornell-box__${technique}__*__seed5)
  b=$(ls -d "$run"/cells/cornell-box__${technique}__*__seed6)
  expect_match "$technique: cell.json records seed and group" "^6 1 ${technique}-group-ok$" \
    "$(/usr/bin/python3 -c "import json,sys; a=json.load(open(sys.argv[1])); b=json.load(open(sys.argv[2])); print(b['seed'], b['seed_index'], sys.argv[3] + '-group-ok' if a['seed_group'] == b['seed_group'] == a['cell'].rsplit('__', 1)[0] else 'bad')" "$a/cell.json" "$b/cell.json" "$technique")"
  # Pixels, not bytes: the files' headers differ.
  identical=$("$PB" metrics --reference "$a/images/frame_0001.exr" --test "$b/images/frame_0001.exr" --json |
    /usr/bin/python3 -c "import json,sys; print(json.load(sys.stdin)['identical'])")
  case "$identical" in True) same=same ;; False) same=differ ;; *) same="not compared" ;; esac
  [ "$technique" = direct ] && want=same || want=differ
  [ "$same" = "$want" ] && pass "$technique: the two seeds' images $same" || fail "$technique: the two seeds' images $same"
  group=$(basename "${a%__seed5}")
  expect_match "$technique: seeds.json has a Z-test per frame" '^3 [0-9][0-9.e-]* True$' \
    "$(/usr/bin/python3 -c "import json,sys; g=json.load(open(sys.argv[1])); z=[f['z_test'] for f in g['frames'] if f['path_class'] == 'combined']; print(len(z), z[0]['p_value'], g['seeds'] == [5, 6])" "$run/seeds/$group/seeds.json")"
  [ -s "$run/seeds/$group/variance_0001_combined.exr" ] && [ -s "$run/seeds/$group/stddev_0001_combined.png" ] &&
    pass "$technique: variance and standard deviation images" || fail "$technique: no variance images"
done
flicker=$(/usr/bin/python3 -c "import csv,sys; rows=[r for r in csv.DictReader(open(sys.argv[1])) if r['path_class'] == 'combined']; print(' '.join(r['flicker'] or '-' for r in rows))" "$(ls -d "$run"/cells/cornell-box__tiled__*__seed6)/metrics.csv")
expect_match "flicker from the second metric frame on" '^- [0-9][0-9.e-]* [0-9][0-9.e-]*$' "$flicker"
expect_match "summary.csv has the seed column" '^seed$' "$(head -1 "$run/summary.csv" | tr ',' '\n' | grep -x seed)"
expect_exit 2 "--seeds 0 is bad input" -- "$PB" run "$cfg" --out "$WORK/bad" --seeds 0
finish
