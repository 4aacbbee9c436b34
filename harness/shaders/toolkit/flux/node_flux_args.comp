#version 460
// NodeFlux, pass 1: the occupied nodes of levels 0 .. stop_level and the resolve's dispatch size.
#include "node_flux_common.glsl"
layout(local_size_x = 1) in;
void main() {
  uint nodes = 0u;
  for (uint l = 0u; l <= push.stop_level; ++l) nodes += hier_count(l);
  resolve_args[0] = (nodes * push.words_per_node + 63u) / 64u;
  resolve_args[1] = 1u;
  resolve_args[2] = 1u;
  resolve_args[3] = nodes;
}
