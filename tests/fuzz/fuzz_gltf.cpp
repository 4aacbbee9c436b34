// libFuzzer: a glTF file, JSON (.gltf, buffers as data URIs) or binary (.glb, from its "glTF"
// magic). pb::scene::parse_gltf returns or throws pb::InputError; nothing else. No external file is
// offered: a URI reads as a missing file.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "photonbench/error.h"
#include "scene/gltf_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  try {
    pb::scene::parse_gltf(
        input, "fuzz-input.gltf",
        [](const std::string&) -> std::optional<std::string> { return std::nullopt; });
  } catch (const pb::InputError&) {
  }
  return 0;
}
