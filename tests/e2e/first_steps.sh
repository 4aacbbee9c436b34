# What a new user tries first answers plainly: validate given a scene file checks it as a scene, `list
# techniques NAME` lists only that technique, and an unknown technique says where else plugins are
# found (--plugin-dir).
source "$(dirname "$0")/lib.bash"
expect_exit 0 "validate takes a scene file" -- "$PB" validate "$SRC/scenes/pillars.yaml"
expect_match "and says it is a valid scene, not a config" \
  "pillars.yaml: a valid scene \('pillars'\), not a benchmark config; a config runs it with scenes:" "$OUT"
printf 'camera: {position: [0, 1, 4], target: [0, 1, 0], fov_deg: 45}\nobjects: 3\n' > "$WORK/bad-scene.yaml"
expect_exit 2 "a broken scene file is bad input" -- "$PB" validate "$WORK/bad-scene.yaml"
expect_no_match "reported as a scene, not as a config of unknown keys" "unknown key 'camera'" "$OUT"

expect_exit 0 "list techniques NAME" -- "$PB" list techniques tiled
expect_match "lists the technique named" "^tiled  \[" "$OUT"
expect_match "and no other" "^1$" "$(printf '%s\n' "$OUT" | grep -cE '^[a-z0-9-]+  \[')"
expect_exit 2 "an unknown name is bad input" -- "$PB" list techniques tiledd
expect_match "with the closest name and --plugin-dir" "did you mean 'tiled'.*--plugin-dir" "$OUT"

write_config "$WORK/unknown.yaml" "scenes: [cornell-box]"
sed -i 's/technique: direct/technique: my-own/' "$WORK/unknown.yaml"
expect_exit 2 "an unknown technique in a config" -- "$PB" validate "$WORK/unknown.yaml"
expect_match "names --plugin-dir" "unknown technique 'my-own'.*--plugin-dir DIR or plugin_dirs: \[DIR\]" "$OUT"
finish
