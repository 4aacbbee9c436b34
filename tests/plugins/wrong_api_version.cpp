// Claims an API version the host does not have: the config naming it must be rejected with exit 2.
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {{"unused", PB_PARAM_INT, 0, 0, 1, nullptr, "", "unused"}};
}
extern "C" __attribute__((visibility("default"))) const pb_technique_descriptor* photonbench_technique(uint32_t) {
  static const pb_technique_descriptor descriptor = {PB_PLUGIN_API_VERSION + 41, "wrong_api_version", "C L | C D L",
                                                     "test: built for another API", kParams, 1, nullptr, nullptr};
  return &descriptor;
}
