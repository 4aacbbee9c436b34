// A module of another day: built against plugin API version 42 (as if from a newer photonbench's
// headers), through the ordinary entry macro. The host must fail only its cells, naming both
// versions and both builds; the macro, seeing a host of another version, hands over no factory.
#define PB_PLUGIN_API_VERSION 42u
#include "direct_only.h"

PB_EXPORT_TECHNIQUE(pb::testing::DirectOnly, "wrong_api_version", "C L | C D L",
                    "test: built for another plugin API", pb::testing::kUnusedParams)
