// Bindings and push constants of directional's passes but the blur (pb::toolkit::DirectionalSplat,
// Paper I §4.7): the hierarchy's buffers, the jobs, then the splatter's own. One binding list and
// one push block (128 bytes, what Vulkan guarantees) for all, so the C++ side binds one list.
//
// Buckets (Paper I §4.7, §5.2: "24 floats per node"): node cid c (the hierarchy's compact node id,
// levels 0 .. the stop level) owns words [24 c, 24 c + 24) of flux_lo and of flux_hi: octant o's
// channel k at 24 c + 3 o + k, a 64-bit fixed-point sum (low and high word, toolkit/atomics.glsl,
// photonbench/toolkit/fixed_point.h): order-independent, so the buckets are the same bits on every
// run, and with a relative error per channel bounded whatever the photon count. After the splat
// (pb::toolkit::NodeFlux::resolve) the low words hold the sums in watts as float bits.
#include "photonbench/photon_layout.h"
#define HIER_BINDING 0
#include "toolkit/hierarchy.glsl"
#define PB_JOBS_BINDING 7
#include "toolkit/jobs.glsl"
layout(std430, binding = 10) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 11) buffer FluxLo { uint flux_lo[]; };
layout(std430, binding = 12) buffer FluxHi { uint flux_hi[]; };
// Per leaf (by cid - the first leaf cid): sample count and the sums of the samples' positions in
// the leaf's AABB (DIR_CENTROID_SCALE units), the weights and centres of the coverage estimate.
layout(std430, binding = 13) buffer LeafStats { uint leaf_stats[]; };
layout(std430, binding = 14) buffer Stats { uint stats[]; };
#define PB_PROFILE_BINDING 15
#define PB_GBUFFER_BINDING 16
layout(binding = 19, rgba32f) uniform image2D irradiance_out;

// Mirrors DirPush (harness/toolkit/src/directional_splat.cpp).
layout(push_constant) uniform Push {
  mat4 view;          // world -> view (right-handed, the camera looks along -z)
  vec4 scale_radius;  // xyz fixed-point units per watt (per channel), w r (m)
  vec4 inverse_area;  // xyz watts per unit, w 1 / (pi r^2)
  uvec4 counts;       // x photons, y stop level (buckets at and above), z DIR_FLAG_*, w top level
  uvec4 limits;       // x loop budget per invocation, y width, z height (pixels)
}
push;

#define DIR_FLAG_DEPOSIT_PAPER 1u  // intersected stop-level nodes get the whole flux
#define DIR_FLAG_WEIGHT_CLIP 2u    // octant weights: solid-angle share above the tangent plane
#define DIR_FLAG_DEBUG_NORMAL 4u   // test hook: irradiance = |world normal|

// Stats words (host-visible): [0..1] bucket deposits (64-bit), [2] traversals cut short by the
// loop budget, [3] photons whose sphere met no occupied node (no deposit, no job).
#define DIR_STAT_DEPOSITS 0u
#define DIR_STAT_TRUNCATED 2u
#define DIR_STAT_MISSED 3u

// Fixed-point scale of the sample-position sums of directional_leaf_counts.comp.
#define DIR_CENTROID_SCALE 4096.0

#include "toolkit/gbuffer.glsl"
#include "toolkit/profile.glsl"
