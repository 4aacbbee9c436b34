# The installable package: `cmake --install` of this build into a temporary prefix, then the example
# technique (examples/out-of-tree-technique/, copied outside the repository) configured and built
# against the installed package alone (find_package(photonbench) + photonbench_add_technique), and run
# with the installed photonbench: from --plugin-dir, then installed into the prefix, where the
# installed executable finds it from its own location. The install copies what this build made.
source "$(dirname "$0")/lib.bash"
BUILD="$(dirname "$PB")"
prefix="$WORK/prefix"
expect_exit 0 "cmake --install into a temporary prefix" -- cmake --install "$BUILD" --prefix "$prefix"
# The image codec module, unless this build links it into the library (PB_IMAGE_CODEC_MODULE=OFF).
codec=$(readelf -d "$(dirname "$PB")/libphotonbench.so" | grep -q "NEEDED.*libOpenImageIO" ||
  echo lib/libphotonbench_image_io.so)
for file in bin/photonbench lib/libphotonbench.so $codec lib/libphotonbench_toolkit.a \
  include/photonbench/plugin.h include/photonbench/context.h include/photonbench/gpu.h \
  include/photonbench/toolkit/technique.h share/photonbench/shaders/toolkit/gbuffer.glsl \
  share/photonbench/shaders/shade.comp lib/cmake/photonbench/photonbenchConfig.cmake \
  lib/cmake/photonbench/photonbenchConfigVersion.cmake lib/cmake/photonbench/photonbenchTargets.cmake \
  lib/photonbench/plugins/direct.so; do
  [ -f "$prefix/$file" ] && pass "installed $file" || fail "not installed: $file"
done
[ ! -e "$prefix/lib/photonbench/plugins/wrong_api_version.so" ] && pass "test plugins stay out" \
  || fail "a test plugin was installed"
installed="$prefix/bin/photonbench"

# Out of the repository: only the installed package may be found (no source tree paths).
cp -r "$SRC/examples/out-of-tree-technique" "$WORK/ambient"
expect_exit 0 "the example configures against the installed package" -- cmake -S "$WORK/ambient" \
  -B "$WORK/ambient/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix"
expect_exit 0 "the example builds" -- cmake --build "$WORK/ambient/build"
# glslc's dependency list of the shader: its includes resolved in the prefix, not the tree.
shader_deps="$(cat "$WORK/ambient/build/spv/ambient.comp.inc.d")"
expect_match "its shader includes come from the installed package" \
  "$prefix/share/photonbench/shaders/toolkit/gbuffer.glsl" "$shader_deps"
if printf '%s\n' "$shader_deps" | grep -q "$SRC/harness"; then
  fail "the example's build read headers or shaders from the source tree"
else
  pass "nothing of the source tree was read"
fi
plugin="$WORK/ambient/build/plugins/ambient.so"
[ -f "$plugin" ] && pass "built $plugin" || fail "no plugin at $plugin"

cat > "$WORK/ambient.yaml" <<YAML
name: ambient
resolution: [64, 36]
frames: {warmup: 0, count: 2, metrics_every: 1}
reference: {samples: 16}
scenes: [cornell-box]
techniques:
  - technique: direct
  - technique: ambient
    params: {ambient: 0.1}
YAML
expect_exit 0 "the installed photonbench runs it from --plugin-dir" -- "$installed" run \
  "$WORK/ambient.yaml" --out "$WORK/run" --plugin-dir "$WORK/ambient/build/plugins"
cells="$WORK/run/cells"
cell() { ls "$cells"/cornell-box__"$1"__*/cell.json 2>/dev/null | head -1; }
expect_match "direct (an installed plugin) ran" "^ok$" "$(json_field "$(cell direct)" status)"
expect_match "ambient (out of tree) ran" "^ok$" "$(json_field "$(cell ambient)" status)"
expect_match "ambient was scored on its own path class" "'indirect'" \
  "$(json_field "$(cell ambient)" metrics)"
expect_match "its counter carries kind and unit" "'ambient_pixels': \{'kind': 'work', 'unit': 'pixels'\}" \
  "$(json_field "$(cell ambient)" counters)"

expect_exit 0 "the example installs into the prefix" -- cmake --install "$WORK/ambient/build" --prefix "$prefix"
expect_exit 0 "the installed photonbench lists its plugins" -- "$installed" list techniques
expect_match "it finds the installed example beside its own plugins, with no --plugin-dir" \
  "^ambient  \[indirect\]" "$OUT"
finish
