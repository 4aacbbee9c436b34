# Bad configs and --set values never crash, hang or lie: exit 2 with a message naming the file,
# line and key (or the --set that set it); sweeps are capped; plugin names are unique.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/config.yaml"
write_config "$cfg" "scenes: [cornell-box]"
expect_exit 0 "the probe config is valid" -- "$PB" validate "$cfg"

# (10) An empty file or one that is not a mapping says so, at the file, not "the command line".
: > "$WORK/empty.yaml"
expect_exit 2 "an empty config" -- "$PB" validate "$WORK/empty.yaml"
expect_match "empty config: says so" "^error: [^ ]*empty.yaml: the file is empty; a config is a mapping" "$OUT"
expect_no_match "empty config: no command-line claim" "command line" "$OUT"
echo "- 1" > "$WORK/list.yaml"
expect_exit 2 "a list as a config" -- "$PB" validate "$WORK/list.yaml"
expect_match "list config: file:line:col" "list.yaml:1:1: a config is a mapping" "$OUT"
head -c 4000 /dev/urandom > "$WORK/binary.yaml"
expect_exit 2 "a binary file as a config" -- "$PB" validate "$WORK/binary.yaml"
# A --set value's error names the --set, not a position in its text.
expect_exit 2 "--set scenes to a missing scene" -- "$PB" validate "$cfg" --set 'scenes=[nowhere]'
expect_match "--set error names the assignment" "config.yaml \(--set scenes=\[nowhere\]\): scenes\[0\]: unknown scene 'nowhere'" "$OUT"
expect_exit 2 "--set frames.count to NaN" -- "$PB" validate "$cfg" --set frames.count=nan
expect_match "--set NaN: finite number" "\(--set frames.count=nan\): frames.count: expected a finite number" "$OUT"

# (8) A key written twice (yaml-cpp would keep one silently).
write_config "$cfg" "scenes: [cornell-box]" "name: u"
expect_exit 2 "a config key written twice" -- "$PB" validate "$cfg"
expect_match "duplicate key names both lines" "config.yaml:7:1: key 'name' is written twice in this mapping \(first at line 1\)" "$OUT"
# Aliases of aliases expand without bound ("billion laughs"): an error, not a hang.
{
  write_config /dev/stdout "scenes: [cornell-box]"
  echo "a0: &a0 [x, x, x, x, x, x, x, x, x, x]"
  for i in 1 2 3 4 5 6 7 8; do echo "a$i: &a$i [*a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1)), *a$((i - 1))]"; done
} > "$WORK/bomb.yaml"
expect_exit 2 "an alias bomb" -- timeout 60 "$PB" validate "$WORK/bomb.yaml"
expect_match "alias bomb: says why" "expands to more than 1000000 nodes" "$OUT"

# (5), (6) The run's name is a folder name: no path, no 300 characters.
write_config "$cfg" "scenes: [cornell-box]"
mkdir -p "$WORK/cwd"
expect_exit 2 "name=../escaped" -- env -C "$WORK/cwd" "$PB" run "$cfg" --set name=../escaped
expect_match "name with a path: names the --set and key" "\(--set name=../escaped\): name: '../escaped' is not a folder name" "$OUT"
[ -z "$(ls -A "$WORK/cwd")" ] && ! ls -d "$WORK"/escaped* >/dev/null 2>&1 && pass "nothing written" || fail "a run folder was written: $(ls -A "$WORK" "$WORK/cwd")"
long=$(printf 'n%.0s' $(seq 1 300))
expect_exit 2 "a 300-character name" -- "$PB" validate "$cfg" --set "name=$long"
expect_match "long name: at most 100" "is not a folder name: use at most 100 letters" "$OUT"
# (5) A list index of 20 digits is out of range, not "stoul".
expect_exit 2 "--set techniques.<20 digits>" -- "$PB" validate "$cfg" --set techniques.99999999999999999999=1
expect_match "huge index: the list's size" "'techniques' has 1 elements, no element 99999999999999999999" "$OUT"
expect_exit 2 "--set with an empty path part" -- "$PB" validate "$cfg" --set frames..count=1
expect_match "empty path part: says so" "no empty part in the path" "$OUT"

# (2) Sweeps are capped with the key and the count, and expand in time linear in their cells.
values=$(seq -s, 16 115)  # 100 values of shadow_map_size
small=$(seq -s, 0.001 0.001 0.1)  # 100 values of shadow_bias or shadow_normal_offset
expect_exit 2 "a sweep of 100 x 100 x 100 cells" -- timeout 60 "$PB" validate "$cfg" \
  --set "techniques.0.params={shadow_map_size: [$values], shadow_bias: [$small], shadow_normal_offset: [$small]}"
expect_match "sweep cap: names the key and the count" "techniques\[0\].params.shadow_normal_offset: this sweep makes 10000 x 100 = 1000000 cells, more than the 10000" "$OUT"
expect_exit 0 "a sweep of exactly 10000 cells validates" -- timeout 120 "$PB" validate "$cfg" \
  --set "techniques.0.params={shadow_map_size: [$values], shadow_bias: [$small]}"
expect_match "10000 cells listed" "valid, 10000 cells" "$OUT"
expect_exit 2 "scenes x sweep beyond the cap" -- timeout 60 "$PB" validate "$cfg" --set 'scenes=[cornell-box, pillars]' \
  --set "techniques.0.params={shadow_map_size: [$values], shadow_bias: [$small]}"
expect_match "scene cap: names the entry and the count" "scenes\[1\]: with technique 'direct' the config expands to 20000 cells or more" "$OUT"

# (10) The unknown-scene message offers scenes, not the other YAML files beside the config.
write_config "$WORK/other-config.yaml" "scenes: [cornell-box]"
expect_exit 2 "an unknown scene" -- "$PB" validate "$cfg" --set 'scenes=[cornel-box]'
expect_match "unknown scene: a suggestion and the shipped scenes" "did you mean 'cornell-box'\?.*available: .*pillars" "$OUT"
expect_no_match "unknown scene: configs are not offered" "available: .*(other-config|config,)" "$OUT"

# (7) validate exits 1 when cells will fail (a plugin that does not load).
write_config "$cfg" "  - technique: not_a_module" "scenes: [cornell-box]" "plugin_dirs: [$TEST_PLUGINS]"
expect_exit 1 "validate with a cell that will fail" -- "$PB" validate "$cfg"
expect_match "will fail: listed and counted" "1 of 2 cells will fail" "$OUT"

# (12) A plugin of a built-in's name in a plugin folder is an error naming both files.
mkdir -p "$WORK/plugins"
cp "$TEST_PLUGINS/sleeps.so" "$WORK/plugins/direct.so"
write_config "$cfg" "scenes: [cornell-box]"
expect_exit 2 "a plugin folder with a direct.so" -- "$PB" validate "$cfg" --plugin-dir "$WORK/plugins"
expect_match "duplicate plugin: both files" "two technique plugins are named 'direct': .*/plugins/direct.so and $WORK/plugins/direct.so" "$OUT"
expect_exit 0 "the same plugin folder twice is no conflict" -- "$PB" validate "$cfg" --plugin-dir "$TEST_PLUGINS" --plugin-dir "$TEST_PLUGINS"
finish
