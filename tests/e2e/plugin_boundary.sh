# The plugin boundary fails only the cells of a plugin that does not fit: one built for another
# plugin API version (tests/plugins/wrong_api_version.cpp) and one declaring a path class no
# reference has (unknown_path_class.cpp), each with a message naming the plugin and both sides,
# while `direct` in the same run succeeds; and a technique counting a counter unlike its
# descriptor's declaration (counter_conflict.cpp), or one it does not declare
# (undeclared_counter.cpp), fails its cell naming it. Cells are small and unscored: seconds.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/boundary.yaml"
cat > "$cfg" <<YAML
name: boundary
resolution: [64, 36]
frames: {warmup: 0, count: 1, metrics_every: 0}
scenes: [cornell-box]
plugin_dirs: [$TEST_PLUGINS]
techniques:
  - technique: wrong_api_version
  - technique: unknown_path_class
  - technique: counter_conflict
  - technique: undeclared_counter
  - technique: direct
YAML
wrong_version="wrong_api_version.so was built for plugin API version 42 \\((GCC|clang) .*, Vulkan-Hpp [0-9]+\\), this photonbench has [0-9]+ \\((GCC|clang) .*, Vulkan-Hpp [0-9]+\\)"
unknown_class="unknown_path_class.so \('unknown_path_class'\) declares path class 'C D D L', which is none of: direct \(C L \| C D L\)"

expect_exit 1 "validate: the config is valid (not exit 2) but cells will fail (exit 1)" -- "$PB" validate "$cfg"
expect_match "validate says the wrong version's cells will fail, and why" "will fail: plugin .*$wrong_version" "$OUT"
expect_match "validate says the unknown class's cells will fail, and why" "will fail: plugin .*$unknown_class" "$OUT"

expect_exit 1 "the run ends with failed cells (exit 1), not as bad input" -- "$PB" run "$cfg" --out "$WORK/run"
cells="$WORK/run/cells"
cell_json() { ls "$cells"/cornell-box__"$1"__*/cell.json 2>/dev/null | head -1; }
for technique in wrong_api_version unknown_path_class counter_conflict undeclared_counter direct; do
  [ -n "$(cell_json $technique)" ] && pass "$technique has a cell record" || fail "$technique: no cell.json"
done
expect_match "direct ran" "^ok$" "$(json_field "$(cell_json direct)" status)"
expect_match "the wrong version failed" "^failed$" "$(json_field "$(cell_json wrong_api_version)" status)"
expect_match "its reason names both versions and builds" "failed to load: plugin .*$wrong_version" \
  "$(json_field "$(cell_json wrong_api_version)" reason)"
expect_match "the unknown class failed" "^failed$" "$(json_field "$(cell_json unknown_path_class)" status)"
expect_match "its reason names the plugin and the known classes" "failed to load: plugin .*$unknown_class" \
  "$(json_field "$(cell_json unknown_path_class)" reason)"
expect_match "a counter counted unlike its declaration fails its cell at the frame, naming both" \
  "technique error at frame 0: counter 'photons_splatted' is declared as work \(photons\) and counted as size \(bytes\)" \
  "$(json_field "$(cell_json counter_conflict)" reason)"
expect_match "a counter the descriptor does not declare fails its cell at the frame, naming it" \
  "technique error at frame 0: counter 'photons_hidden' \(work, photons\) is not declared in the technique's descriptor" \
  "$(json_field "$(cell_json undeclared_counter)" reason)"
finish
