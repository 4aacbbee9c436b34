#version 460
// Pass "query" (seed 003 §5, Eq. 1): per G-buffer sample on a diffuse surface, the toolkit BVH's
// point walk (toolkit/bvh/bvh_walk.glsl) into every node whose box contains the point, nodes of at
// most T hits walked as leaves (§5.3: the walk's leaf size); its any-hit hook, called for every
// footprint of a leaf reached (the footprint's box left untested: the ellipsoid test is exact and
// reads the record the hook reads anyway, in Morton order at pb_bvh_slot), adds
// flux / (pi |a1 x a2|) times the kernel (uniform, or Epanechnikov: PD_FLAG_EPANECHNIKOV) when
// the footprint's ellipsoid contains the point, photons
// arriving from behind the surface left out (PD_FLAG_NORMAL_GATE). Radiance = albedo / pi x
// irradiance. The walk's steps (nodes and footprints) are budgeted against llvmpipe's loop limit;
// a walk cut short is counted.
#include "pd_common.glsl"
#include "toolkit/atomics.glsl"
#define PB_BVH_WALK_BINDING PD_BVH_BINDING
#include "toolkit/bvh/bvh_walk.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
shared uint group_tested[64], group_contributing[64], group_nodes[64], group_fetched[64];

vec3 x, n;
vec3 irradiance = vec3(0.0);
uint contributing = 0u;

bool pb_bvh_hit(uint item) {
  PdFootprint f = sorted_footprints[pb_bvh_slot];
  if (!(f.area > 0.0)) return true;
  if ((push.flags & PD_FLAG_NORMAL_GATE) != 0u && dot(f.incoming, n) <= 0.0) return true;
  vec3 d = x - f.position;
  vec3 u = vec3(dot(f.inverse0, d), dot(f.inverse1, d), dot(f.inverse2, d));
  float q2 = dot(u, u);
  if (q2 > 1.0) return true;
  ++contributing;
  irradiance +=
      f.flux_density * ((push.flags & PD_FLAG_EPANECHNIKOV) != 0u ? 2.0 * (1.0 - q2) : 1.0);
  return true;  // every footprint containing the point adds to the sum
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint id = gl_LocalInvocationIndex;
  vec3 albedo;
  bool lit =
      pb_in_frame(pixel, uvec2(push.width, push.height)) && pb_lit_sample(pixel, x, n, albedo);
  bool truncated = false;
  if (lit) {
    pb_bvh_budget = push.budget;
    pb_bvh_leaf_size = control[PD_CTL_THRESHOLD];
    pb_bvh_test_item_boxes = false;
    truncated = !pb_bvh_point_walk(x);
  }
  if (pb_in_frame(pixel, uvec2(push.width, push.height)))
    imageStore(radiance, pixel,
               vec4(lit ? albedo * float(1.0 / PD_PI) * irradiance : vec3(0.0), 1.0));
  group_tested[id] = pb_bvh_boxes_tested;
  group_contributing[id] = contributing;
  group_nodes[id] = pb_bvh_nodes_met;
  group_fetched[id] = pb_bvh_nodes_visited;
  if (lit) atomicAdd(control[PD_CTL_QUERIES], 1u);
  if (truncated) atomicAdd(control[PD_CTL_TRUNCATED], 1u);
  barrier();
  for (uint step = 32u; step > 0u; step >>= 1u) {
    if (id < step) {
      group_tested[id] += group_tested[id + step];
      group_contributing[id] += group_contributing[id + step];
      group_nodes[id] += group_nodes[id + step];
      group_fetched[id] += group_fetched[id + step];
    }
    barrier();
  }
  if (id == 0u) {
    PB_ADD64(control, PD_CTL_TESTED, group_tested[0]);
    PB_ADD64(control, PD_CTL_CONTRIBUTING, group_contributing[0]);
    PB_ADD64(control, PD_CTL_NODES_VISITED, group_nodes[0]);
    PB_ADD64(control, PD_CTL_NODES_FETCHED, group_fetched[0]);
  }
}
