#version 460
// Pass "reduce" (seed 003 §6.2's scan, §5.3): the groups' footprint areas summed, T_auto = c sum
// A_i / A_surfaces (footprint.h's t_auto), and the threshold this frame's BVH uses.
#include "pd_common.glsl"
layout(local_size_x = 256) in;
shared float sums[256];
void main() {
  uint id = gl_LocalInvocationID.x;
  float sum = 0.0;
  for (uint g = id; g < push.groups; g += 256u) sum += partials[g];
  sums[id] = sum;
  barrier();
  for (uint step = 128u; step > 0u; step >>= 1u) {
    if (id < step) sums[id] += sums[id + step];
    barrier();
  }
  if (id != 0u) return;
  float total = sums[0];
  uint t_auto = 1u;
  if (push.surface_area > 0.0)
    t_auto = uint(clamp(round(push.t_constant * total / push.surface_area), 1.0, 1048576.0));
  control[PD_CTL_AREA] = floatBitsToUint(total);
  control[PD_CTL_T_AUTO] = t_auto;
  control[PD_CTL_THRESHOLD] = push.fixed_threshold > 0u ? push.fixed_threshold : t_auto;
}
