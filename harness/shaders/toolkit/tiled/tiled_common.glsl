// Bindings and push constants of every tiled pass (pb::toolkit::TiledSplat, Paper I §5.1 after Mara
// et al. 2013): one binding list and one push block for all, so the C++ side binds one list.
#include "photonbench/photon_layout.h"
#define PB_LISTS_BINDING 0
#include "toolkit/photon_lists.glsl"
layout(std430, binding = 5) readonly buffer Photons { PhotonRecord photons[]; };
// Per tile: [0, n) zmin bits, [n, 2n) zmax bits (Paper I Table 1's "Tiles z-Bounds").
layout(std430, binding = 6) buffer Bounds { uint bounds[]; };
// [0..1] photons read in the estimate (64-bit), [2..3] read but rejected.
layout(std430, binding = 7) buffer Stats { uint stats[]; };
#define PB_GBUFFER_BINDING 8
#include "toolkit/gbuffer.glsl"
layout(binding = 11, rgba32f) uniform image2D indirect_out;

#define TILED_STAT_READ 0u
#define TILED_STAT_REJECTED 2u
#define TILED_MODE_COUNT 0u
#define TILED_MODE_INSERT 1u

// Mirrors TiledPush (harness/toolkit/src/tiled_splat.cpp). View depth is the distance along the
// viewing axis (metres), the quantity the per-tile z-bounds hold.
layout(push_constant) uniform Push {
  mat4 view_projection;
  vec4 depth_plane;  // view depth of world point p = dot(depth_plane.xyz, p) + depth_plane.w
  uint width, height, tiles_x, tiles_y;
  uint photon_count, tile_size, tile_count, mode;  // mode: TILED_MODE_* (splat)
  float radius;  // splat: the sphere tested (the insert run's may differ: list-check test hook)
  float estimate_radius;
  uint list_first;  // radiance-estimate: this dispatch's slice of each list
  uint pad0;
}
push;
