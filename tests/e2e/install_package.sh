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

# Out of the repository: only the installed package may be found (no source tree paths). The
# example is configured and built by its README's own commands, word for word (no build type: the
# package must supply one that runs).
cp -r "$SRC/examples/out-of-tree-technique" "$WORK/ambient"
readme_build=$(grep -E '^cmake -S \. -B build' "$SRC/examples/out-of-tree-technique/README.md")
expect_match "the README's build commands are the ones run here" \
  '^cmake -S \. -B build -G Ninja -DCMAKE_PREFIX_PATH=PREFIX && cmake --build build$' "$readme_build"
cd "$WORK/ambient" || exit 1
expect_exit 0 "the example configures against the installed package" -- \
  cmake -S . -B build -G Ninja -DCMAKE_PREFIX_PATH="$prefix"
expect_exit 0 "the example builds" -- cmake --build build
host_type=$(grep '^CMAKE_BUILD_TYPE:' "$BUILD/CMakeCache.txt" | cut -d= -f2)
expect_match "the package gave the example photonbench's build type ($host_type)" \
  "^CMAKE_BUILD_TYPE:STRING=$host_type$" "$(grep '^CMAKE_BUILD_TYPE:' build/CMakeCache.txt)"
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
  "$WORK/ambient.yaml" --out "$WORK/run" --plugin-dir build/plugins
cells="$WORK/run/cells"
cell() { ls "$cells"/cornell-box__"$1"__*/cell.json 2>/dev/null | head -1; }
expect_match "direct (an installed plugin) ran" "^ok$" "$(json_field "$(cell direct)" status)"
expect_match "ambient (out of tree) ran" "^ok$" "$(json_field "$(cell ambient)" status)"
expect_match "ambient was scored on its own path class" "'indirect'" \
  "$(json_field "$(cell ambient)" metrics)"
expect_match "its counter carries kind and unit" "'ambient_pixels': \{'kind': 'work', 'unit': 'pixels'\}" \
  "$(json_field "$(cell ambient)" counters)"

# Built with another NDEBUG than photonbench's, the plugin is refused at load, naming the difference,
# instead of crashing in Vulkan-Hpp's dispatchers (photonbench is built with NDEBUG here).
expect_match "photonbench is built with NDEBUG" "^(Release|RelWithDebInfo|MinSizeRel)$" "$host_type"
expect_exit 0 "the example configures as a Debug build" -- \
  cmake -S . -B debug-build -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_PREFIX_PATH="$prefix"
expect_exit 0 "the Debug build builds" -- cmake --build debug-build
expect_exit 1 "its cell fails" -- "$installed" run "$WORK/ambient.yaml" --out "$WORK/debug-run" \
  --plugin-dir debug-build/plugins
debug_cell=$(ls "$WORK"/debug-run/cells/cornell-box__ambient__*/cell.json | head -1)
expect_match "refused at load, naming NDEBUG and the build type to use" \
  "failed to load: .*built without NDEBUG .*photonbench: built with NDEBUG .*-DCMAKE_BUILD_TYPE=Release" \
  "$(json_field "$debug_cell" reason)"
expect_match "the installed direct still ran beside it" "^ok$" \
  "$(json_field "$(ls "$WORK"/debug-run/cells/cornell-box__direct__*/cell.json | head -1)" status)"

expect_exit 0 "the example installs into the prefix" -- cmake --install "$WORK/ambient/build" --prefix "$prefix"
expect_exit 0 "the installed photonbench lists its plugins" -- "$installed" list techniques
expect_match "it finds the installed example beside its own plugins, with no --plugin-dir" \
  "^ambient  \[indirect\]" "$OUT"
finish
