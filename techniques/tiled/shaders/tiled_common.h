// Push constants shared by every tiled pass (one block, so the C++ side fills one struct).
// view_projection and the depth plane come from the frame's camera; depth is view-space distance
// along the viewing axis (metres), the quantity Paper I's per-tile z-bounds hold (Table 1: one
// (zmin, zmax) float pair per tile).
layout(push_constant) uniform Push {
  mat4 view_projection;
  vec4 depth_plane;  // view depth of world point p = dot(depth_plane.xyz, p) + depth_plane.w
  uint width, height, tiles_x, tiles_y;
  uint photon_count, tile_size, capacity, tile_count;
  float radius;
  uint list_first;  // radiance-estimate: the slice [list_first, list_first + list_slice) of each list
  uint list_slice;
  uint pad0;
} push;

// Stats block (host-visible): [0] list entries wanted, [1] entries dropped for want of capacity,
// [2..3] photons read in the estimate (lo, hi words), [4..5] photons read but rejected (lo, hi).
#define STAT_ENTRIES 0
#define STAT_DROPPED 1
#define STAT_READ 2
#define STAT_REJECTED 4
