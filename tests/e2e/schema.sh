# `photonbench schema` validates every shipped config and scene with a real JSON Schema validator
# (python3-jsonschema), and each error-path case of tests/unit/bad_input_test.cpp's table is
# rejected by the schema and by `photonbench validate` alike, except the few
# semantic errors a schema cannot express, listed below with the reason.
source "$(dirname "$0")/lib.bash"
check() { /usr/bin/python3 "$SRC/tests/e2e/schema_check.py" "$@"; }

expect_exit 0 "schema config" -- "$PB" schema config --plugin-dir "$TEST_PLUGINS"
printf '%s\n' "$OUT" | grep -v '^schema: ' > "$WORK/config.json"
expect_exit 0 "schema scene" -- "$PB" schema scene
printf '%s\n' "$OUT" > "$WORK/scene.json"
expect_match "the plugins' parameters are in the config schema" '"techniques.direct.params"' "$(cat "$WORK/config.json")"
expect_match "a parameter keeps its range" '"maximum": 4096' "$(cat "$WORK/config.json")"

# configs/stress/ holds stability files (`photonbench stability`), not benchmark configs.
mapfile -t configs < <(find "$SRC/configs" -name '*.yaml' -not -path "$SRC/configs/stress/*" | sort)
expect_exit 0 "every shipped config (${#configs[@]}) validates against the schema" -- check "$WORK/config.json" "${configs[@]}"
expect_exit 0 "every shipped scene validates against the schema" -- check "$WORK/scene.json" "$SRC"/scenes/*.yaml "$SRC"/scenes/stress/*.yaml

cfg="$WORK/bad.yaml"
base=("name: t" "resolution: [64, 36]" "frames: {warmup: 0, count: 2, metrics_every: 0}"
  "scenes: [cornell-box]" "techniques:" "  - technique: direct")
write() { printf '%s\n' "$@" > "$cfg"; }
# rejected NAME: the config in $cfg fails both `validate` (exit 2) and the schema.
rejected() {
  expect_exit 2 "$1: validate rejects it" -- "$PB" validate "$cfg" --plugin-dir "$TEST_PLUGINS"
  expect_exit 1 "$1: the schema rejects it" -- check "$WORK/config.json" "$cfg"
}
# fails_its_cells NAME: a plugin that does not load fails only its cells (validate exits 1, not 2);
# the schema leaves such a plugin out, so it rejects a config naming it.
fails_its_cells() {
  expect_exit 1 "$1: validate says its cells will fail" -- "$PB" validate "$cfg" --plugin-dir "$TEST_PLUGINS"
  expect_exit 1 "$1: the schema rejects it" -- check "$WORK/config.json" "$cfg"
}
# semantic NAME REASON: `validate` rejects the config in $cfg, the schema cannot (REASON).
semantic() {
  expect_exit 2 "$1: validate rejects it" -- "$PB" validate "$cfg" --plugin-dir "$TEST_PLUGINS"
  expect_exit 0 "$1: semantic, the schema accepts it ($2)" -- check "$WORK/config.json" "$cfg"
}
write "${base[@]}"
expect_exit 0 "the probe config is valid" -- "$PB" validate "$cfg"
expect_exit 0 "the probe config satisfies the schema" -- check "$WORK/config.json" "$cfg"

# bad_input_test.cpp: the config rows
write "${base[@]}" "  - technique: [direct"; rejected "bad YAML syntax (the YAML parser)"
write "${base[@]}" "frame: {count: 3}"; rejected "unknown top-level key"
write "${base[@]/count: 2/count: many}"; rejected "wrong type"
write "${base[@]/count: 2/count: -3}"; rejected "frames.count out of range"
write "${base[@]/\[64, 36\]/[64, 100000]}"; rejected "resolution out of range"
write "${base[@]/technique: direct/technique: drect}"; rejected "unknown technique"
write "${base[@]}" "    params: {shadow_map_sise: 256}"; rejected "unknown technique parameter"
write "${base[@]}" "    params: {shadow_map_size: [256, 8]}"; rejected "swept value out of range"
write "${base[@]/\[cornell-box\]/[cornell-box, {scene: pillars, params: {shadow_map_sise: 256}}]}"
rejected "unknown parameter in a scene's overrides"
write "${base[@]/\[cornell-box\]/[cornell-box, {scene: pillars, params: {shadow_map_size: [64, 8]}}]}"
rejected "scene override out of range"
write "${base[@]/technique: direct/technique: wrong_api_version}"
fails_its_cells "plugin built for another API version"
write "${base[@]/cornell-box/no-such-scene}"
semantic "missing scene file" "scene names are looked up in folders"
write "${base[@]/technique: direct/technique: aaps}" "    params: {density_min: 8, density_max: 4}"
semantic "aaps: a density ceiling below its floor" "a technique's check relates two parameters"
write "${base[@]/technique: direct/technique: tiled}" "    params: {tile_size: [32, 12]}"
semantic "tiled: a tile side that is not a multiple of 8" "a technique's check, not a range"
# bad_input_test.cpp: the config file rows
: > "$cfg"; rejected "an empty config"
echo "- 1" > "$cfg"; rejected "a list as a config"
head -c 4000 /dev/urandom > "$cfg"; rejected "a binary file as a config"
write "${base[@]}" "name: u"; rejected "a key written twice (the YAML parser)"
write "${base[@]/name: t/name: ../escaped}"; rejected "a name with a path"
write "${base[@]/name: t/name: $(printf 'n%.0s' $(seq 1 300))}"; rejected "a 300-character name"
write "${base[@]/count: 2/count: 1}" "    params: {shadow_map_size: [$(seq -s, 16 115)], shadow_bias: [$(seq -s, 0.001 0.001 0.1)], shadow_normal_offset: [$(seq -s, 0.001 0.001 0.1)]}"
semantic "a sweep of 1000000 cells" "the cap is on the product of the sweeps"
write "${base[@]/cornell-box/cornel-box}"; semantic "an unknown scene" "scene names are looked up in folders"
# Not file cases: --set paths (techniques.<20 digits>, frames..count), a folder of duplicate
# plugins, and an alias bomb (the reader's node limit; a validator walking the expanded tree is
# what the limit exists to prevent).

# bad_input_test.cpp's scene rows: each scene fails `validate` of a config naming it and, unless semantic, the schema.
scene_file="$WORK/s.yaml"
scene() {
  local camera="camera: {position: [0, 1, 3], target: [0, 1, 0], fov_deg: 40}"
  local light="  - {type: point, position: [0, 2, 0], intensity: 1}"
  local object="  - {shape: {type: box}, material: white}" extra=""
  for kv in "$@"; do
    case "$kv" in
      CAMERA=*) camera="${kv#CAMERA=}" ;; LIGHT=*) light="${kv#LIGHT=}" ;;
      OBJECT=*) object="${kv#OBJECT=}" ;; EXTRA=*) extra="${kv#EXTRA=}" ;;
    esac
  done
  printf '%s\n' "purpose: probe" "$extra" "$camera" "lights:" "$light" "materials:" \
    "  white: {type: diffuse}" "objects:" "$object" > "$scene_file"
  write "${base[@]/\[cornell-box\]/[$scene_file]}"
}
scene_rejected() {
  expect_exit 2 "$1: validate rejects it" -- "$PB" validate "$cfg"
  expect_exit 1 "$1: the schema rejects it" -- check "$WORK/scene.json" "$scene_file"
}
scene_semantic() {
  expect_exit 2 "$1: validate rejects it" -- "$PB" validate "$cfg"
  expect_exit 0 "$1: semantic, the schema accepts it ($2)" -- check "$WORK/scene.json" "$scene_file"
}
scene
expect_exit 0 "the probe scene is valid" -- "$PB" validate "$cfg"
expect_exit 0 "the probe scene satisfies the schema" -- check "$WORK/scene.json" "$scene_file"
scene "CAMERA=camera: {position: [0, 1e23, 3], target: [0, 1, 0], fov_deg: 40}"; scene_rejected "camera position 1e23"
scene "LIGHT=  - {type: point, position: [0, 1e308, 0], intensity: 1}"; scene_rejected "light position 1e308"
scene "LIGHT=  - {type: point, position: [0, 1e999, 0], intensity: 1}"; scene_rejected "light position 1e999"
scene "OBJECT=  - {shape: {type: box}, material: white, transform: {translate: [1e308, 0, 0]}}"
scene_rejected "transform translate 1e308"
scene "OBJECT=  - {shape: {type: height_field, waves: [{amplitude: 0.1, wavelength: 1, direction: [1e23, 0]}]}, material: white}"
scene_rejected "wave direction 1e23"
scene "LIGHT=  - {type: point, position: [0, 2, 0], intensity: 1, color: [nan, 1, 1]}"; scene_rejected "NaN in a colour"
scene "CAMERA=camera: {position: [0, 1, 3], target: [0, 1, 0], fov_deg: $(printf 'x%.0s' $(seq 1 500))}"
scene_rejected "a 500-character number"
scene "LIGHT=  - {type: sphere, position: [0, 2, 0], intensity: 1}"; scene_rejected "an unknown light type"
scene "OBJECT=  - {shape: {type: box, radius: 1}, material: white}"; scene_rejected "a key of another shape"
scene "EXTRA=fps: 30"; printf 'fps: 60\n' >> "$scene_file"; scene_rejected "a scene key written twice (the YAML parser)"
: > "$scene_file"; scene_rejected "an empty scene file"
head -c 3000 /dev/urandom > "$scene_file"; scene_rejected "a binary scene file"
cp "$SRC/tests/data/scenes/plain.obj" "$scene_file"; scene_rejected "an OBJ file given as a scene"
scene "CAMERA=camera: {position: [0, 1, 3], target: [0, 1, 3], fov_deg: 40}"
scene_semantic "camera on its target" "geometry at a frame"
scene "CAMERA=camera: {position: [0, 1, 3], target: [0, 5, 3], fov_deg: 40}"
scene_semantic "camera looking along up" "geometry at a frame"
scene "LIGHT=  - {type: spot, position: [0, 2, 0], target: [0, 2, 0], intensity: 1}"
scene_semantic "spot light aimed at its own position" "geometry at a frame"
scene "LIGHT=  - {type: directional, position: [1, 2, 0], target: [1, 2, 0], irradiance: 1}"
scene_semantic "directional light whose position is its target" "geometry at a frame"
scene "EXTRA=frames: 60" "CAMERA=camera: {position: {keys: [[0, [0, 1, 3]], [1, [0, 1, 0]], [2, [0, 1, 3]]]}, target: [0, 1, 0], fov_deg: 40}"
scene_semantic "camera on its target at a later frame" "the animation evaluated at each frame"
printf 'mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 2 0 0\nusemtl a\nf 1 2 3\n' > "$WORK/m.obj"
printf 'newmtl a\nKd 0.5 0.5 0.5\n' > "$WORK/m.mtl"
scene "OBJECT=  - {shape: {type: obj, file: m.obj}}"
scene_semantic "an OBJ of only degenerate faces" "the content of a file the scene names"
# Not file cases: a folder or /dev/zero as a scene, OBJ and MTL file contents (the OBJ above
# stands for them), `reference --frames` past a degenerate frame.
finish
