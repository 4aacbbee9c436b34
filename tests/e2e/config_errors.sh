# Every kind of bad input exits 2 with a message naming file:line:col and the key.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/bad.yaml"

write() { printf '%s\n' "$@" > "$cfg"; }
base=(
  "name: t"
  "resolution: [64, 36]"
  "frames: {warmup: 0, count: 2, metrics_every: 0}"
  "scenes: [cornell-box]"
  "techniques:"
  "  - technique: direct"
)

write "${base[@]}" "  - technique: [direct"
expect_exit 2 "bad YAML syntax" -- "$PB" validate "$cfg"
expect_match "bad YAML syntax names file:line:col" "bad.yaml:[0-9]+:[0-9]+: YAML syntax error" "$OUT"

write "${base[@]}" "frame: {count: 3}"
expect_exit 2 "unknown top-level key" -- "$PB" validate "$cfg"
expect_match "unknown key names location, key and suggestion" "bad.yaml:7:1: frame: unknown key; did you mean 'frames'" "$OUT"

write "${base[@]/count: 2/count: many}"
expect_exit 2 "wrong type" -- "$PB" validate "$cfg"
expect_match "wrong type names location and key" "bad.yaml:3:[0-9]+: frames.count: expected a number, got 'many'" "$OUT"

write "${base[@]/\[64, 36\]/[64, 100000]}"
expect_exit 2 "out-of-range value" -- "$PB" validate "$cfg"
expect_match "out of range names location and range" "bad.yaml:2:[0-9]+: resolution\[1\]: value 100000 is out of range" "$OUT"

write "${base[@]/cornell-box/no-such-scene}"
expect_exit 2 "missing scene file" -- "$PB" validate "$cfg"
expect_match "missing scene names location" "bad.yaml:4:[0-9]+: scenes\[0\]: .*no-such-scene" "$OUT"

write "${base[@]/technique: direct/technique: drect}"
expect_exit 2 "unknown technique" -- "$PB" validate "$cfg"
expect_match "unknown technique names location and suggestion" "bad.yaml:6:[0-9]+: techniques\[0\].technique: unknown technique 'drect'; did you mean 'direct'" "$OUT"

write "${base[@]}" "    params: {shadow_map_sise: 256}"
expect_exit 2 "unknown technique parameter" -- "$PB" validate "$cfg"
expect_match "unknown parameter suggests the schema name" "bad.yaml:7:[0-9]+: techniques\[0\].params.shadow_map_sise: unknown key; did you mean 'shadow_map_size'" "$OUT"

write "${base[@]}" "    params: {shadow_map_size: [256, 8]}"
expect_exit 2 "swept value out of the schema's range" -- "$PB" validate "$cfg"
expect_match "sweep element out of range" "bad.yaml:7:[0-9]+: techniques\[0\].params.shadow_map_size\[1\]: value 8 is out of range \[16, 4096\]" "$OUT"

# A technique's check of its values together (the descriptor's `check`): before any work, at the
# key it blames, for `validate` and `run` alike.
write "${base[@]/technique: direct/technique: aaps}" "    params: {density_min: 8, density_max: 4}"
expect_exit 2 "aaps: a density ceiling below its floor" -- "$PB" validate "$cfg"
expect_match "aaps's check names file:line:col and the key" "bad.yaml:7:[0-9]+: techniques\[0\].params.density_max: 4 is below density_min = 8 \(0: no ceiling\) \(aaps\)" "$OUT"
write "${base[@]/technique: direct/technique: tiled}" "    params: {tile_size: [32, 12]}"
expect_exit 2 "tiled: a tile side that is not a multiple of 8" -- "$PB" validate "$cfg"
expect_match "the toolkit's check names file:line:col and the key" "bad.yaml:7:[0-9]+: techniques\[0\].params.tile_size: 12 is not a multiple of 8" "$OUT"
expect_exit 2 "run refuses it too" -- "$PB" run "$cfg" --out "$WORK/refused"
[ ! -e "$WORK/refused" ] && pass "run wrote nothing (no reference, no cell)" || fail "run wrote $WORK/refused"

scenes="[cornell-box, {scene: pillars, params: {shadow_map_sise: 256}}]"
write "${base[@]/\[cornell-box\]/$scenes}"
expect_exit 2 "unknown parameter in a scene's overrides" -- "$PB" validate "$cfg"
expect_match "scene override names location and suggestion" "bad.yaml:4:[0-9]+: scenes\[1\].params.shadow_map_sise: unknown key; did you mean 'shadow_map_size'" "$OUT"

scenes="[cornell-box, {scene: pillars, params: {shadow_map_size: [64, 8]}}]"
write "${base[@]/\[cornell-box\]/$scenes}"
expect_exit 2 "scene override out of the schema's range" -- "$PB" validate "$cfg"
expect_match "scene override element out of range" "bad.yaml:4:[0-9]+: scenes\[1\].params.shadow_map_size\[1\]: value 8 is out of range" "$OUT"

scenes="[cornell-box, {scene: pillars, params: {shadow_map_size: [64, 128]}}]"
write "${base[@]/\[cornell-box\]/$scenes}"
expect_exit 0 "a scene's overrides sweep that scene only" -- "$PB" validate "$cfg"
expect_match "one cornell-box cell and two pillars cells" "valid, 3 cells" "$OUT"
expect_match "pillars cells take the scene's value" "pillars__direct__[0-9a-f]+ .*shadow_map_size=128" "$OUT"

write "${base[@]}"
expect_exit 2 "--set with a bad value" -- "$PB" validate "$cfg" --set frames.count=-3
expect_match "--set error says it came from the command line" "frames.count: value -3 is out of range" "$OUT"
expect_exit 2 "run rejects bad input before running" -- "$PB" run "$cfg" --out "$WORK/run" --set frames.count=-3
[ ! -e "$WORK/run/run.json" ] && pass "nothing written for a rejected config" || fail "a rejected config wrote run.json"

expect_exit 0 "a valid config validates" -- "$PB" validate "$cfg" --set 'techniques.0.params={shadow_map_size: [128, 256]}'
expect_match "sweep expands into two cells" "valid, 2 cells" "$OUT"
write "${base[@]/technique: direct/technique: sleeps}"
expect_exit 2 "a test plugin is not found without its folder" -- "$PB" validate "$cfg"
expect_exit 0 "--plugin-dir adds a plugin folder" -- "$PB" validate "$cfg" --plugin-dir "$TEST_PLUGINS"
expect_exit 0 "key+=value appends to a list" -- "$PB" validate "$cfg" --set "plugin_dirs+=$TEST_PLUGINS"
finish
