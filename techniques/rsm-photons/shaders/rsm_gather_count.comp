#version 460
// rsm-photons gathering, pass 2 of 5, "Photon Count" (seed 000 §6.3): one invocation per kernel
// (indirect dispatch); each tile its bounding sphere covers counts it, so every tile learns exactly
// how many entries its list needs.
#include "rsm_gather.glsl"
layout(local_size_x = 64) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= state.kernel_count) return;
  uvec2 first, last;
  if (!covered_tiles(kernels[i], first, last)) return;
  for (uint y = first.y; y <= last.y; ++y)
    for (uint x = first.x; x <= last.x; ++x) atomicAdd(tiles[y * view.grid.x + x].x, 1u);
}
