#version 460
// Pass "query" (seed 003 §5, Eq. 1): per G-buffer sample on a diffuse surface, a walk of the BVH
// into every node whose box contains the point; in a leaf (a run, or a node of at most T hits)
// every footprint whose ellipsoid contains the point adds flux / (pi |a1 x a2|) times the kernel
// (uniform, or Epanechnikov: PD_FLAG_EPANECHNIKOV), photons arriving from behind the surface left
// out (PD_FLAG_NORMAL_GATE). Radiance = albedo / pi x irradiance. Loop steps (nodes and
// footprints) are budgeted against llvmpipe's loop limit; a walk cut short is counted.
#include "pd_common.glsl"
#include "toolkit/atomics.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
shared uint group_tested[64], group_contributing[64], group_nodes[64], group_fetched[64];

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  uint id = gl_LocalInvocationIndex;
  vec3 x, n, albedo;
  bool lit =
      pb_in_frame(pixel, uvec2(push.width, push.height)) && pb_lit_sample(pixel, x, n, albedo);
  vec3 irradiance = vec3(0.0);
  uint tested = 0u, contributing = 0u, visited = 0u, fetched = 0u, steps = 0u;
  bool truncated = false;
  uint runs = control[PD_CTL_RUNS], threshold = control[PD_CTL_THRESHOLD];
  bool epanechnikov = (push.flags & PD_FLAG_EPANECHNIKOV) != 0u;
  bool gate = (push.flags & PD_FLAG_NORMAL_GATE) != 0u;
  if (lit && runs > 0u) {
    uint stack[64];
    uint top = 0u;
    stack[top++] = 0u;
    while (top > 0u) {
      if (++steps > push.budget) {
        truncated = true;
        break;
      }
      uint i = stack[--top];
      PdNode node = nodes[i];
      ++fetched;  // a node's own box is in its record: read before it is tested (§6.3 differs)
      if (any(lessThan(x, node.lo)) || any(greaterThan(x, node.hi))) continue;
      ++visited;
      if (node.left != PD_NONE && node.count > threshold) {
        if (top + 2u <= 64u) {
          stack[top++] = node.right;
          stack[top++] = node.left;
        } else {
          truncated = true;
        }
        continue;
      }
      uint end = node.first + node.count;
      for (uint j = node.first; j < end; ++j) {
        if (++steps > push.budget) {
          truncated = true;
          break;
        }
        ++tested;
        PdFootprint f = sorted_footprints[j];
        if (!(f.area > 0.0)) continue;
        if (gate && dot(f.incoming, n) <= 0.0) continue;
        vec3 d = x - f.position;
        vec3 u = vec3(dot(f.inverse0, d), dot(f.inverse1, d), dot(f.inverse2, d));
        float q2 = dot(u, u);
        if (q2 > 1.0) continue;
        ++contributing;
        irradiance += f.flux_density * (epanechnikov ? 2.0 * (1.0 - q2) : 1.0);
      }
      if (truncated) break;
    }
  }
  if (pb_in_frame(pixel, uvec2(push.width, push.height)))
    imageStore(radiance, pixel,
               vec4(lit ? albedo * float(1.0 / PD_PI) * irradiance : vec3(0.0), 1.0));
  group_tested[id] = tested;
  group_contributing[id] = contributing;
  group_nodes[id] = visited;
  group_fetched[id] = fetched;
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
