// direct: G-buffer plus shadow-mapped direct light, and no indirect light at all.
//
// The lower bound every chart shows: what a renderer gets with no global illumination. It is also
// the template for a technique: it reads its parameters in setup, and in render calls the shared
// passes that every photon technique reuses (gbuffer, direct-light, shade), each of which records
// its own named pass. A photon technique adds its passes between direct-light and shade and hands
// its indirect radiance image to shade.
//
// Fails (by design) wherever indirect light matters: it estimates only C D L (and emitters seen
// directly). Shadows of quad and disc lights are hard (one shadow cube at the light's centre).
#include "photonbench/toolkit/technique.h"

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {

using pb::toolkit::kDirectLightParams;
using pb::toolkit::kShadowParams;

constexpr auto kSchema = pb::join_rows(kShadowParams, kDirectLightParams);

// Its parameters are the shared passes' shadow settings (the toolkit's rows; their defaults the
// shared passes' own: photonbench/context.h).
class Direct final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    const pb::toolkit::ShadowParams shadow = kShadowParams.read(params);
    ctx.shared().configure_shadows(shadow.map_size, shadow.bias, shadow.normal_offset);
    pb::toolkit::configure_direct_light(ctx, params);
  }

  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
};

}  // namespace

PB_EXPORT_TECHNIQUE(
    Direct, "direct", "C L | C D L",
    "G-buffer + direct light (shadow-mapped, or the many-light estimator); no indirect "
    "light",
    kSchema.rows)
