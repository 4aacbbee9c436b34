// libFuzzer: any lines as --set assignments (one per line) over configs/quick.yaml.
// pb::config::parse_config returns or throws pb::InputError; nothing else.
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "config/config.h"
#include "photonbench/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string base = [] {
    std::ifstream in(PB_SOURCE_DIR "/configs/quick.yaml");
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }();
  std::vector<std::string> overrides;
  std::istringstream lines(std::string(reinterpret_cast<const char*>(data), size));
  for (std::string line; std::getline(lines, line) && overrides.size() < 16;)
    overrides.push_back(line);
  try {
    pb::config::parse_config(base, PB_SOURCE_DIR "/configs/quick.yaml", overrides);
  } catch (const pb::InputError&) {
  }
  return 0;
}
