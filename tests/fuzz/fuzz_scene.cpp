// libFuzzer: any text as a scene file. pb::scene::parse_scene (parsing, range checks,
// tessellation, the camera and light checks over the default animation) returns or throws
// pb::InputError; nothing else.
#include <cstddef>
#include <cstdint>
#include <string>

#include "photonbench/error.h"
#include "scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    // A scene in scenes/, so that the pool's OBJ (pool/floor-tiles.obj) is found.
    pb::scene::parse_scene(text, PB_SOURCE_DIR "/scenes/fuzz-input.yaml");
  } catch (const pb::InputError&) {
  }
  return 0;
}
