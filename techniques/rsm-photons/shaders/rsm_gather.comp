#version 460
// rsm-photons gathering, pass 5 of 5, "Gathering" (seed 000 §6.3): one workgroup per tile loads
// the tile's kernels into shared memory, 64 at a time; each pixel transforms its two receiver
// points (those of its block's nearest and farthest G-buffer pixels, §6.2.1, rsm_block.glsl)
// into each kernel's frame, keeps the kernels whose ellipsoid holds both (Eq. 6.5) and sums their
// irradiance and power-weighted light direction: what the splat's additive blending sums, in the
// same two targets. A tile wider than the 8x8 group is done in 8x8 blocks.
#include "rsm_gather.glsl"
// After the G-buffer bindings it reads:
#include "rsm_block.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
shared Kernel cache[64];
void main() {
  uint tile = gl_WorkGroupID.y * view.grid.x + gl_WorkGroupID.x;
  uint first = tiles[tile].y;
  // The entries this tile's list holds (those past the capacity were dropped by the copy pass).
  uint count = first < state.capacity ? min(tiles[tile].x, state.capacity - first) : 0u;
  uint side = view.size.w;
  uvec2 origin = gl_WorkGroupID.xy * side;
  ivec2 pixels = ivec2(view.grid.zw);
  int scale = int(view.size.z);
  for (uint by = 0u; by < side; by += 8u)
    for (uint bx = 0u; bx < side; bx += 8u) {
      uvec2 local = uvec2(bx, by) + gl_LocalInvocationID.xy;
      ivec2 pixel = ivec2(origin + local);
      bool receives = local.x < side && local.y < side && all(lessThan(pixel, pixels));
      vec3 near_point = vec3(0.0), far_point = vec3(0.0);
      if (receives) {
        // The ray through the pixel's centre, as the splat's fragment sees it.
        vec2 ndc = (vec2(pixel) + 0.5) / vec2(pixels) * 2.0 - 1.0;
        vec4 p = view.inverse_view_projection * vec4(ndc, 0.5, 1.0);
        vec3 ray = normalize(p.xyz / p.w - view.camera.xyz);
        receives = block_receivers(pixel, scale, ivec2(view.size.xy), view.camera.xyz, ray,
                                   near_point, far_point);
      }
      vec3 e = vec3(0.0), wdir = vec3(0.0);
      for (uint base = 0u; base < count; base += 64u) {
        uint n = min(64u, count - base);
        if (gl_LocalInvocationIndex < n)
          cache[gl_LocalInvocationIndex] = kernels[indices[first + base + gl_LocalInvocationIndex]];
        barrier();
        if (receives)
          for (uint j = 0u; j < n; ++j) {
            Kernel k = cache[j];
            if (!inside_kernel(k, near_point) || !inside_kernel(k, far_point)) continue;
            vec3 ek = k.irradiance.rgb;
            e += ek;
            wdir += (ek.r + ek.g + ek.b) * k.light_dir.xyz;
          }
        barrier();
      }
      if (local.x < side && local.y < side && all(lessThan(pixel, pixels))) {
        imageStore(accumulation, pixel, vec4(e, wdir.x));
        imageStore(direction, pixel, vec4(wdir.yz, 0.0, 0.0));
      }
    }
}
