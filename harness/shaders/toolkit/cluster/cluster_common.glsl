// Bindings and push constants of every cluster pass (pb::toolkit::ClusterSplat, Paper I §4): the
// hierarchy's buffers, the jobs, the per-node lists, then the splatter's own. One binding list for
// all passes, so the C++ side binds one list. The including shader defines PB_PROFILE_SLOT first.
#include "photonbench/photon_layout.h"
#define HIER_BINDING 0
#include "toolkit/hierarchy.glsl"
#define PB_JOBS_BINDING 7
#include "toolkit/jobs.glsl"
#define PB_LISTS_BINDING 10
#include "toolkit/photon_lists.glsl"
layout(std430, binding = 15) readonly buffer Photons { PhotonRecord photons[]; };
// trivial: per cid, the 64-bit fixed-point sums of the node flux (pb::toolkit::NodeFlux): words
// [3 c, 3 c + 3) of r, g, b, low words here and high words there; after the splat, the low words
// hold the sums in watts as float bits.
layout(std430, binding = 16) buffer NodeFluxLo { uint node_flux_lo[]; };
layout(std430, binding = 17) buffer NodeFluxHi { uint node_flux_hi[]; };
layout(std430, binding = 18) buffer Stats { uint stats[]; };
#define PB_PROFILE_BINDING 19
#define PB_GBUFFER_BINDING 20
layout(binding = 23, rgba32f) uniform image2D indirect_out;

// Mirrors ClusterPush (harness/toolkit/src/cluster_splat.cpp).
layout(push_constant) uniform Push {
  mat4 view;  // world -> view (the hierarchy's space)
  uint photon_count;
  float radius;           // the sphere this pass tests (insert: x the list-check test hook)
  uint flags;             // CLUSTER_VARIANT_MASK bits: the variant
  uint top_level;         // splat/top: the level where it stops and emits (photon, node) jobs
  uint mode;              // splat/count, splat/insert: CLUSTER_MODE_COUNT or _INSERT
  uint budget;            // loop steps one invocation may take (toolkit/traverse.glsl)
  uint list_first;        // radiance-estimate: this dispatch's slice of a sample's lists
  float estimate_radius;  // radiance-estimate: the photons' radius
  vec4 units_per_watt;    // trivial: fixed-point scale of the node flux, per channel
  vec4 pad0;
}
push;

#define CLUSTER_VARIANT_MASK 3u
#define CLUSTER_VARIANT_PLAIN 0u
#define CLUSTER_VARIANT_CONE 1u
#define CLUSTER_VARIANT_TRIVIAL 2u
#define CLUSTER_MODE_COUNT 0u
#define CLUSTER_MODE_INSERT 1u
uint cluster_variant() { return push.flags & CLUSTER_VARIANT_MASK; }

// Stats words (host-visible; ClusterSplat::report reads them after the frame).
#define CLUSTER_STAT_READ 0u       // 64-bit: list entries read in the estimate
#define CLUSTER_STAT_REJECTED 2u   // 64-bit: of those, outside the sphere or from below
#define CLUSTER_STAT_TRIVIAL 4u    // trivial accepts (photon flux added to a node)
#define CLUSTER_STAT_CONE 5u       // cone rejects (nodes skipped by the normal-cone test)
#define CLUSTER_STAT_TRUNCATED 6u  // traversals (a photon's from the roots, or a job's) cut short
#define CLUSTER_STAT_WORDS 8u

#include "toolkit/gbuffer.glsl"
#include "toolkit/profile.glsl"
