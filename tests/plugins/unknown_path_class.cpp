// Declares a path class no reference has ("C D D L" is neither a class name nor one's light path
// expression): loading must fail its cells naming the plugin, instead of scoring it on `combined`
// alone.
#include "direct_only.h"

PB_EXPORT_TECHNIQUE(pb::testing::DirectOnly, "unknown_path_class", "C D D L",
                    "test: a path class no reference has", pb::testing::kUnusedParams)
