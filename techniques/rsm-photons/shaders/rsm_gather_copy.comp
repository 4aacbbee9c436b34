#version 460
// rsm-photons gathering, pass 4 of 5, "Copy" (seed 000 §6.3): one invocation per kernel again, the
// same cull; the kernel's index (not its data) appended to each covered tile's list. An entry past
// the index buffer's estimated size is dropped and counted (the thesis's "clearly visible
// corruption" when the estimate is too low).
#include "rsm_gather.glsl"
layout(local_size_x = 64) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= state.kernel_count) return;
  uvec2 first, last;
  if (!covered_tiles(kernels[i], first, last)) return;
  for (uint y = first.y; y <= last.y; ++y)
    for (uint x = first.x; x <= last.x; ++x) {
      uint t = y * view.grid.x + x;
      uint slot = tiles[t].y + atomicAdd(tiles[t].z, 1u);
      if (slot < state.capacity)
        indices[slot] = i;
      else
        atomicAdd(state.dropped, 1u);
    }
}
