# Bad scene files (and the OBJ/MTL files they name) never crash, hang or lie: each is exit 2 with a
# message naming the file, the line and the key, from validate, run and reference alike.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/config.yaml"

# scene FILE [REPLACEMENT...]: the probe scene with the camera, light or object lines replaced by
# CAMERA=..., LIGHT=..., OBJECT=..., EXTRA=... (an extra top-level line).
scene() {
  local file="$1" camera="camera: {position: [0, 1, 3], target: [0, 1, 0], fov_deg: 40}"
  local light="  - {type: point, position: [0, 2, 0], intensity: 1}"
  local object="  - {shape: {type: box}, material: white}" extra=""
  shift
  for kv in "$@"; do
    case "$kv" in
      CAMERA=*) camera="${kv#CAMERA=}" ;;
      LIGHT=*) light="${kv#LIGHT=}" ;;
      OBJECT=*) object="${kv#OBJECT=}" ;;
      EXTRA=*) extra="${kv#EXTRA=}" ;;
    esac
  done
  printf '%s\n' "purpose: probe scene for the bad-input tests" "$extra" "$camera" "lights:" "$light" \
    "materials:" "  white: {type: diffuse}" "objects:" "$object" > "$file"
}
validate_scene() {  # NAME REGEX [REPLACEMENT...]: the config naming the scene fails validation
  local name="$1" regex="$2"
  shift 2
  scene "$WORK/s.yaml" "$@"
  write_config "$cfg" "scenes: [$WORK/s.yaml]"
  expect_exit 2 "$name" -- "$PB" validate "$cfg"
  expect_match "$name: message" "$regex" "$OUT"
}

scene "$WORK/s.yaml"
write_config "$cfg" "scenes: [$WORK/s.yaml]"
expect_exit 0 "the probe scene itself is valid" -- "$PB" validate "$cfg"

# (1) A degenerate camera, and huge coordinates anywhere, are rejected where they are read.
validate_scene "camera on its target" \
  "s.yaml:3:9: camera: at frame 0 \(t = 0 s\) the position \(0, 1, 3\) equals the target" \
  "CAMERA=camera: {position: [0, 1, 3], target: [0, 1, 3], fov_deg: 40}"
validate_scene "camera looking along up" "s.yaml:3:9: camera: at frame 0 .*parallel to up" \
  "CAMERA=camera: {position: [0, 1, 3], target: [0, 5, 3], fov_deg: 40}"
validate_scene "camera position 1e23" \
  "s.yaml:3:[0-9]+: camera.position\[1\]: value 1e23 is out of range \[-1000000, 1000000\]" \
  "CAMERA=camera: {position: [0, 1e23, 3], target: [0, 1, 0], fov_deg: 40}"
validate_scene "light position 1e308" "s.yaml:5:[0-9]+: lights\[0\].position\[1\]: value 1e308 is out of range" \
  "LIGHT=  - {type: point, position: [0, 1e308, 0], intensity: 1}"
validate_scene "light position 1e999 (beyond a double)" "lights\[0\].position\[1\]: '1e999' is beyond the range of a double" \
  "LIGHT=  - {type: point, position: [0, 1e999, 0], intensity: 1}"
validate_scene "transform translate 1e308" "s.yaml:9:[0-9]+: objects\[0\].transform.translate\[0\]: value 1e308 is out of range" \
  "OBJECT=  - {shape: {type: box}, material: white, transform: {translate: [1e308, 0, 0]}}"
validate_scene "wave direction 1e23" "objects\[0\].shape.waves\[0\].direction\[0\]: value 1e23 is out of range" \
  "OBJECT=  - {shape: {type: height_field, waves: [{amplitude: 0.1, wavelength: 1, direction: [1e23, 0]}]}, material: white}"
validate_scene "NaN in a colour" "lights\[0\].color\[0\]: expected a finite number, got 'nan'" \
  "LIGHT=  - {type: point, position: [0, 2, 0], intensity: 1, color: [nan, 1, 1]}"
# (8) Lights aimed at their own position.
validate_scene "spot light aimed at its own position" \
  "s.yaml:5:5: lights\[0\]: at frame 0 \(t = 0 s\) the target \(0, 2, 0\) is the light's own position" \
  "LIGHT=  - {type: spot, position: [0, 2, 0], target: [0, 2, 0], intensity: 1}"
validate_scene "directional light whose position is its target" \
  "s.yaml:5:5: lights\[0\]: at frame 0 .*is the light's own position" \
  "LIGHT=  - {type: directional, position: [1, 2, 0], target: [1, 2, 0], irradiance: 1}"
# A camera that reaches its target later in its default animation (t = 1 s is frame 30).
moving="CAMERA=camera: {position: {keys: [[0, [0, 1, 3]], [1, [0, 1, 0]], [2, [0, 1, 3]]]}, target: [0, 1, 0], fov_deg: 40}"
validate_scene "camera on its target at a later frame" "s.yaml:3:9: camera: at frame 30 \(t = 1 s\)" "EXTRA=frames: 60" "$moving"

# `reference` and `run` exit 2 with the location, not SIGABRT inside Embree, and write nothing.
scene "$WORK/degenerate.yaml" "CAMERA=camera: {position: [0, 1, 3], target: [0, 1, 3], fov_deg: 40}"
expect_exit 2 "reference on a degenerate camera" -- "$PB" reference "$WORK/degenerate.yaml" --frames 0 \
  --resolution 16x16 --samples 2 --cache "$WORK/cache"
expect_match "reference names the camera" "degenerate.yaml:3:9: camera: at frame 0" "$OUT"
# The default animation (frames 0-1) is fine; the camera reaches its target at frame 30.
scene "$WORK/late.yaml" "EXTRA=frames: 2" "$moving"
expect_exit 2 "reference --frames at a degenerate frame" -- "$PB" reference "$WORK/late.yaml" \
  --frames 28:32 --resolution 16x16 --samples 2 --cache "$WORK/cache"
expect_match "reference names the frame" "late.yaml:3:9: camera: at frame 30" "$OUT"
[ -z "$(ls -A "$WORK/cache" 2>/dev/null)" ] && pass "no reference rendered before the error" || fail "references were rendered: $(ls "$WORK/cache")"
write_config "$cfg" "scenes: [$WORK/late.yaml]"
expect_exit 2 "run with frames past the degenerate one" -- "$PB" run "$cfg" --out "$WORK/run" \
  --set frames.count=40
expect_match "run names the scene entry, camera and frame" \
  "config.yaml:[0-9]+:[0-9]+: scenes\[0\]: .*late.yaml:3:9: camera: at frame 30" "$OUT"
[ ! -e "$WORK/run/run.json" ] && pass "run wrote no run.json" || fail "run wrote run.json"
expect_exit 0 "the same run within the good frames validates" -- "$PB" validate "$cfg" --set frames.count=20

# (7) validate reads the scene files: an empty file, a binary, an OBJ given as a scene.
: > "$WORK/empty.yaml"
write_config "$cfg" "scenes: [$WORK/empty.yaml]"
expect_exit 2 "an empty scene file" -- "$PB" validate "$cfg"
expect_match "empty scene: says so, at the scene entry" "scenes\[0\]: .*empty.yaml: the file is empty; a scene is a mapping" "$OUT"
expect_no_match "empty scene: no command-line claim" "command line" "$OUT"
head -c 3000 /dev/urandom > "$WORK/binary.yaml"
write_config "$cfg" "scenes: [$WORK/binary.yaml]"
expect_exit 2 "a binary scene file" -- "$PB" validate "$cfg"
cp "$SRC/tests/data/scenes/plain.obj" "$WORK/mesh.yaml"
write_config "$cfg" "scenes: [$WORK/mesh.yaml]"
expect_exit 2 "an OBJ file given as a scene" -- "$PB" validate "$cfg"
expect_match "OBJ as a scene: not a scene file" "mesh.yaml:1:1: not a scene file: a scene is a mapping" "$OUT"
# (10) A folder or a device as a scene says what it is.
mkdir -p "$WORK/folder.yaml"
write_config "$cfg" "scenes: [$WORK/folder.yaml]"
expect_exit 2 "a folder as a scene" -- "$PB" validate "$cfg"
expect_match "folder: says it is a directory" "folder.yaml: is a directory, not a scene file" "$OUT"
write_config "$cfg" "scenes: [/dev/zero]"
expect_exit 2 "/dev/zero as a scene" -- timeout 60 "$PB" validate "$cfg"
expect_match "/dev/zero: says it is no regular file" "/dev/zero: is not a regular file" "$OUT"
# An error never echoes a whole line of whatever it was given.
long=$(printf 'x%.0s' $(seq 1 500))
validate_scene "a 500-character number" "fov_deg: expected a number, got 'x{40}\.\.\.'" \
  "CAMERA=camera: {position: [0, 1, 3], target: [0, 1, 0], fov_deg: $long}"
[ "${#OUT}" -lt 400 ] && pass "the message stays short (${#OUT} characters)" || fail "message of ${#OUT} characters"
# (8) A key written twice is an error naming both lines, not "last one wins".
scene "$WORK/s.yaml"
printf 'fps: 30\nfps: 60\n' >> "$WORK/s.yaml"
write_config "$cfg" "scenes: [$WORK/s.yaml]"
expect_exit 2 "a scene key written twice" -- "$PB" validate "$cfg"
expect_match "duplicate key: second line, first line" "s.yaml:11:1: key 'fps' is written twice in this mapping \(first at line 10\)" "$OUT"

# OBJ and MTL files: (10) only degenerate faces, (8) MTL values that are not finite or too large.
obj_scene() {  # OBJ_TEXT MTL_TEXT: a scene with one OBJ object
  printf '%b' "$1" > "$WORK/m.obj"
  printf '%b' "$2" > "$WORK/m.mtl"
  scene "$WORK/s.yaml" "OBJECT=  - {shape: {type: obj, file: m.obj}}"
  write_config "$cfg" "scenes: [$WORK/s.yaml]"
}
tri="mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"
obj_scene "$tri" "newmtl a\nKd 0.5 0.5 0.5\n"
expect_exit 0 "the probe OBJ is valid" -- "$PB" validate "$cfg"
obj_scene "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 2 0 0\nusemtl a\nf 1 2 3\nf 1 3 2\n" "newmtl a\nKd 0.5 0.5 0.5\n"
expect_exit 2 "an OBJ of only degenerate faces" -- "$PB" validate "$cfg"
expect_match "degenerate OBJ: names the OBJ and says why" "objects\[0\].shape.file: .*m.obj: all 2 faces of the OBJ file have zero area" "$OUT"
obj_scene "$tri" "newmtl a\nKd nan 0.5 0.5\n"
expect_exit 2 "MTL Kd nan" -- "$PB" validate "$cfg"
expect_match "Kd nan: names the MTL file and line" "m.mtl:2: 'Kd': 'nan' is not a finite number" "$OUT"
obj_scene "$tri" "newmtl a\nKd 0.5 0.5 0.5\nKe 1e999 1 1\n"
expect_exit 2 "MTL Ke 1e999" -- "$PB" validate "$cfg"
expect_match "Ke 1e999: names the MTL file and line" "m.mtl:3: 'Ke': '1e999' is not a finite number" "$OUT"
obj_scene "mtllib m.mtl\nv 0 0 0\nv 1e30 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n" "newmtl a\n"
expect_exit 2 "an OBJ vertex at 1e30" -- "$PB" validate "$cfg"
expect_match "OBJ vertex: names the OBJ line" "m.obj:3: 'v': 1e\+30 is out of range" "$OUT"
obj_scene "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" ""
expect_exit 2 "mtllib /dev/zero does not hang" -- timeout 60 "$PB" validate "$cfg"

# (12) Disc area lights: a finite radius, a normal that is not the zero vector, exactly one of
# radiance and power, and no quad keys.
validate_scene "disc radius 0" "s.yaml:5:[0-9]+: lights\[0\].radius: value 0 is out of range \[0.0001, 10000\]" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0, radiance: 1}"
validate_scene "disc radius 1e5" "s.yaml:5:[0-9]+: lights\[0\].radius: value 1e5 is out of range" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 1e5, radiance: 1}"
validate_scene "disc normal zero" "s.yaml:5:[0-9]+: lights\[0\].normal: a direction must not be the zero vector" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], normal: [0, 0, 0], radius: 0.2, radiance: 1}"
validate_scene "disc without a normal" "s.yaml:5:[0-9]+: lights\[0\]: missing required key 'normal'" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], radius: 0.2, radiance: 1}"
validate_scene "disc with radiance and power" "s.yaml:5:[0-9]+: lights\[0\]: a disc light needs exactly one of 'radiance' or 'power'" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0.2, radiance: 1, power: 3}"
validate_scene "disc with a quad's edge" "s.yaml:5:[0-9]+: lights\[0\].edge_u: unknown key" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0.2, radiance: 1, edge_u: [1, 0, 0]}"
validate_scene "disc radiance negative" "s.yaml:5:[0-9]+: lights\[0\].radiance: value -1 is out of range" \
  "LIGHT=  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0.2, radiance: -1}"

# (11) The shipped pool scene (a deforming water surface) builds without an Embree error.
expect_exit 0 "reference of pool" -- "$PB" reference pool --frames 0 --resolution 16x16 --samples 2 \
  --cache "$WORK/pool-cache"
expect_no_match "pool: no embree error" "embree error" "$OUT"
finish
