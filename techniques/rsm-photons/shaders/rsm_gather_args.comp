#version 460
// rsm-photons gathering, pass 1 of 5, "Indirect Argument" (seed 000 §6.3): the count and copy
// passes' dispatch sizes from the photon count, and the allocation counters cleared.
#include "rsm_gather.glsl"
layout(local_size_x = 1) in;
void main() {
  state.dispatch = uvec3((state.kernel_count + 63u) / 64u, 1u, 1u);
  state.allocated = 0u;
  state.dropped = 0u;
}
