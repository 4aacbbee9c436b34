#version 460
// rsm-photons gathering, pass 3 of 5, "Allocation" (seed 000 §6.3): each tile's list placed in the
// shared index buffer by an atomic counter (no prefix sum: the order of the lists varies, their
// contents do not).
#include "rsm_gather.glsl"
layout(local_size_x = 64) in;
void main() {
  uint t = gl_GlobalInvocationID.x;
  if (t >= view.grid.x * view.grid.y) return;
  tiles[t].y = atomicAdd(state.allocated, tiles[t].x);
  tiles[t].z = 0u;
}
