#version 460
// Pass "grid" (Ch. 12 step 4): one workgroup a screen cell finds whether any pixel within k of the
// cell holds a photon (the thesis's occlusion query on the cell's quad with the stencil test > 0;
// widened by the filter's reach, so a cell beside a photon is not skipped), and writes the empty
// cells' radiance as 0, which the filter then skips.
#include "sc_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

shared uint any_photon;

void main() {
  uint cell = gl_WorkGroupID.y * push.grid + gl_WorkGroupID.x;
  ivec2 lo = ivec2(gl_WorkGroupID.xy * uvec2(push.cell_width, push.cell_height));
  ivec2 hi = min(lo + ivec2(push.cell_width, push.cell_height), ivec2(push.width, push.height));
  if (gl_LocalInvocationIndex == 0u) any_photon = 0u;
  barrier();
  ivec2 reach_lo = max(lo - ivec2(push.k), ivec2(0));
  ivec2 reach_hi = min(hi + ivec2(push.k), ivec2(push.width, push.height));
  uint found = 0u;
  for (int y = reach_lo.y + int(gl_LocalInvocationID.y); y < reach_hi.y; y += 8)
    for (int x = reach_lo.x + int(gl_LocalInvocationID.x); x < reach_hi.x; x += 8)
      found |= counts[uint(y) * push.width + uint(x)] != 0u ? 1u : 0u;
  if (found != 0u) atomicOr(any_photon, 1u);
  barrier();
  bool has_photons = any_photon != 0u;
  if (gl_LocalInvocationIndex == 0u) cell_active[cell] = has_photons ? 1u : 0u;
  if (has_photons) return;
  for (int y = lo.y + int(gl_LocalInvocationID.y); y < hi.y; y += 8)
    for (int x = lo.x + int(gl_LocalInvocationID.x); x < hi.x; x += 8)
      imageStore(caustics, ivec2(x, y), vec4(0.0, 0.0, 0.0, 1.0));
}
