// libFuzzer: an OBJ file and the MTL file its `mtllib` names, as one input "OBJ text \0 MTL text"
// (no \0: no MTL file). pb::scene::parse_obj returns or throws pb::InputError; nothing else.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "photonbench/error.h"
#include "scene/obj_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t split = input.find('\0');
  const std::string obj = input.substr(0, split);
  const std::optional<std::string> mtl =
      split == std::string::npos ? std::nullopt : std::optional(input.substr(split + 1));
  try {
    pb::scene::parse_obj(obj, "fuzz-input.obj",
                         [&](const std::string&) -> std::optional<std::string> { return mtl; });
  } catch (const pb::InputError&) {
  }
  return 0;
}
