// A module of plugin API version 4, before the tracer policies: the host of version 5 must refuse
// it, naming both versions and what version 5 changed.
#define PB_PLUGIN_API_VERSION 4u
#include "direct_only.h"

PB_EXPORT_TECHNIQUE(pb::testing::DirectOnly, "api_v4", "C L | C D L",
                    "test: built for plugin API version 4", pb::testing::kUnusedParams)
