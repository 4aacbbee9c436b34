// A module of plugin API version 3, before budget knobs: the host of version 4 must still load it,
// as a technique without budget knobs (a match refuses it with a message saying so).
#define PB_PLUGIN_API_VERSION 3u
#include "direct_only.h"

PB_EXPORT_TECHNIQUE(pb::testing::DirectOnly, "api_v3", "C L | C D L",
                    "test: built for plugin API version 3", pb::testing::kUnusedParams)
