// libFuzzer: any text as a benchmark config. pb::config::parse_config returns or throws
// pb::InputError; nothing else (tests/fuzz/CMakeLists.txt).
#include <cstddef>
#include <cstdint>
#include <string>

#include "config/config.h"
#include "photonbench/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    // A config in configs/: plugin_dirs and scene folders resolve against a real folder.
    pb::config::parse_config(text, PB_SOURCE_DIR "/configs/fuzz-input.yaml", {});
  } catch (const pb::InputError&) {
  }
  return 0;
}
