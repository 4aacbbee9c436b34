// rsm-photons tile-based photon gathering (seed 000 §6.3, after Mara et al.): the resources its
// five compute passes share and the tile cull two of them repeat. Screen tiles of `view.size.w`
// pixels at the splat resolution; each tile gets the list of kernels whose bounding sphere may
// cover one of its pixels, as indices into the kernel buffer in one shared index buffer whose size
// is estimated up front (§6.3: "we can not explicitly define size for the indirect indexing buffer
// and thus are required to estimate"; the entries beyond it are dropped and counted).
#include "rsm_kernel.glsl"
layout(std430, binding = 0) readonly buffer Kernels { Kernel kernels[]; };
layout(std430, binding = 1) buffer State {
  uvec3 dispatch;     // the count and copy passes' indirect arguments (pass 1 writes them)
  uint kernel_count;  // the photons drawn (the host writes it: the thesis's append counter)
  uint allocated;     // index entries the tiles asked for (the allocation pass's atomic counter)
  uint dropped;       // entries beyond the capacity, not written
  uint capacity;      // entries the index buffer holds (the host's estimate)
  uint pad;
}
state;
layout(std430, binding = 2) buffer Tiles { uvec4 tiles[]; };  // x: count, y: offset, z: fill
layout(std430, binding = 3) buffer Indices { uint indices[]; };
layout(std430, binding = 4) readonly buffer View {
  mat4 view_projection;
  mat4 inverse_view_projection;
  vec4 camera;  // xyz
  uvec4 size;   // x, y: full-resolution width, height; z: splat scale (1, 2, 4); w: tile side
  uvec4 grid;   // x, y: tiles across and down; z, w: splat-resolution width, height
}
view;
layout(binding = 5, rgba32f) uniform readonly image2D gbuffer_position;  // w: camera distance
layout(binding = 6, rgba32f) uniform readonly image2D gbuffer_normal;
layout(binding = 7, rgba32f) uniform writeonly image2D accumulation;  // E.rgb, w dir.x
layout(binding = 8, rgba32f) uniform writeonly image2D direction;     // w dir.y, w dir.z

// The tiles the kernel's bounding sphere covers on screen (§6.4: "our tile-culling was done using a
// sphere defined around the kernel"): the screen rectangle of the projected corners of the sphere's
// bounding box, in tiles, the whole screen where a corner is not in front of the camera. A pixel
// whose centre's ray meets the ellipsoid lies in that rectangle, so the cull drops no pixel the
// splat would reach. False where the rectangle misses the screen.
bool covered_tiles(Kernel k, out uvec2 first, out uvec2 last) {
  float r = max(k.axis_u.w, max(k.axis_t.w, k.axis_n.w));
  vec2 lo = vec2(1e30), hi = vec2(-1e30);
  for (int i = 0; i < 8; ++i) {
    vec3 corner = k.center.xyz + r * vec3((i & 1) != 0 ? 1.0 : -1.0, (i & 2) != 0 ? 1.0 : -1.0,
                                          (i & 4) != 0 ? 1.0 : -1.0);
    vec4 c = view.view_projection * vec4(corner, 1.0);
    if (c.w <= 1e-6) {
      lo = vec2(-1.0), hi = vec2(1.0);
      break;
    }
    lo = min(lo, c.xy / c.w), hi = max(hi, c.xy / c.w);
  }
  if (hi.x < -1.0 || hi.y < -1.0 || lo.x > 1.0 || lo.y > 1.0) return false;
  vec2 pixels = vec2(view.grid.zw);
  uvec2 p0 = uvec2(floor((clamp(lo, -1.0, 1.0) * 0.5 + 0.5) * pixels));
  uvec2 p1 = uvec2(floor((clamp(hi, -1.0, 1.0) * 0.5 + 0.5) * pixels));
  first = min(p0 / view.size.w, view.grid.xy - 1u);
  last = min(p1 / view.size.w, view.grid.xy - 1u);
  return true;
}
