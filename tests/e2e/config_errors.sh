# The executable's exit codes for its input, one run each: 2 for bad input, with "error: " and a
# message naming file:line:col on stderr; 1 for a valid config some of whose cells will fail; 0 for a
# valid one (--plugin-dir adding a plugin folder). Every kind of bad input is a row of
# tests/unit/bad_input_test.cpp, which makes the calls `validate` and `run` make. Also `reference`,
# which checks a scene's frames before it renders any, and builds the pool scene's deforming water
# surface in Embree without an error.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/bad.yaml"

write_config "$cfg" "scenes: [cornell-box]" "  - technique: [direct"
expect_exit 2 "bad YAML syntax" -- "$PB" validate "$cfg"
expect_match "bad YAML syntax names file:line:col" "^error: [^ ]*bad.yaml:[0-9]+:[0-9]+: YAML syntax error" "$OUT"

write_config "$cfg" "  - technique: not_a_module" "scenes: [cornell-box]" "plugin_dirs: [$TEST_PLUGINS]"
expect_exit 1 "validate with a cell that will fail" -- "$PB" validate "$cfg"
expect_match "will fail: listed and counted" "1 of 2 cells will fail" "$OUT"

write_config "$cfg" "scenes: [cornell-box]"
sed -i 's/technique: direct/technique: sleeps/' "$cfg"
expect_exit 0 "--plugin-dir adds a plugin folder" -- "$PB" validate "$cfg" --plugin-dir "$TEST_PLUGINS"
expect_match "one cell of the test plugin" "valid, 1 cells" "$OUT"

# `reference` exits 2 with the location, not SIGABRT inside Embree, and renders nothing: the camera
# reaches its target at frame 30 (t = 1 s) of the scene's default animation.
printf '%s\n' "purpose: a camera that reaches its target at t = 1 s" "frames: 2" \
  "camera: {position: {keys: [[0, [0, 1, 3]], [1, [0, 1, 0]], [2, [0, 1, 3]]]}, target: [0, 1, 0], fov_deg: 40}" \
  "lights:" "  - {type: point, position: [0, 2, 0], intensity: 1}" "materials:" "  white: {type: diffuse}" \
  "objects:" "  - {shape: {type: box}, material: white}" > "$WORK/late.yaml"
expect_exit 2 "reference --frames at a degenerate frame" -- "$PB" reference "$WORK/late.yaml" \
  --frames 28:32 --resolution 16x16 --samples 2 --cache "$WORK/cache"
expect_match "reference names the frame" "late.yaml:3:9: camera: at frame 30" "$OUT"
[ -z "$(ls -A "$WORK/cache" 2>/dev/null)" ] && pass "no reference rendered before the error" || fail "references were rendered: $(ls "$WORK/cache")"

expect_exit 0 "reference of pool" -- "$PB" reference pool --frames 0 --resolution 16x16 --samples 2 \
  --cache "$WORK/pool-cache"
expect_no_match "pool: no embree error" "embree error" "$OUT"
finish
