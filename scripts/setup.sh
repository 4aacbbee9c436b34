#!/usr/bin/env bash
# Installs the Debian packages photonbench needs. Idempotent: when all are present it only checks.
#
#   scripts/setup.sh           what the main job needs (scripts/bench.sh): build photonbench and its
#                              plugins, run a config, write the report
#   scripts/setup.sh --tests   that and what the tests, the bench programs and CI's checks need
#                              (scripts/test.sh, .ci/run)
set -euo pipefail
main_packages=(
  build-essential cmake ninja-build pkg-config git
  libvulkan-dev mesa-vulkan-drivers glslc
  libembree-dev
  libopenimageio-dev libopenexr-dev
  openimageio-tools  # its CMake package names these tools (iconvert...): find_package fails without
  libyaml-cpp-dev libglm-dev libtbb-dev
  libcli11-dev libfmt-dev libtinyobjloader-dev nlohmann-json3-dev
  libtinygltf-dev  # glTF 2.0 scenes (harness/src/scene/gltf_import.cpp)
  glmark2-data  # the Stanford bunny of scenes/bunny-glass.yaml (/usr/share/glmark2/models/bunny.obj)
  python3 python3-matplotlib python3-numpy python3-scipy python3-pandas python3-jinja2  # the report
  ffmpeg  # `video:` runs' videos (photonbench video; without it they are skipped, never failed)
)
test_packages=(
  libgtest-dev
  vulkan-validationlayers  # every test runs with the Vulkan validation layers on
  embree-tools     # bench/bench_trace: Embree's own pathtracer, the anchor
  python3-skimage  # bench/bench_metrics: the SSIM and PSNR anchor
  python3-jsonschema  # tests/e2e/schema.sh checks configs and scenes against `photonbench schema`
  clang-format     # scripts/check_format.sh
  assimp-testmodels  # tests/unit/gltf_import_test.cpp loads its glTF 2.0 fixtures
  clang-14 libfuzzer-14-dev  # scripts/fuzz.sh: libFuzzer targets with ASan/UBSan (tests/fuzz/)
  chromium  # tests/e2e/report_html.sh opens the HTML report headless
  slurm-wlm munge  # tests/e2e/slurm_sweep.sh starts a one-node Slurm (slurmctld, slurmd, sbatch)
)
packages=("${main_packages[@]}")
case "${1:-}" in
  --tests) packages+=("${test_packages[@]}") ;;
  "") ;;
  *) echo "usage: scripts/setup.sh [--tests]" >&2; exit 2 ;;
esac
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all ${#packages[@]} packages present"
fi
