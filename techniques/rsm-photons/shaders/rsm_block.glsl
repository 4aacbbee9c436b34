// rsm-photons: the receiver points of one reduced-resolution pixel, as the splat and the tile
// gathering both test them (seed 000 §6.2.1). Included after the declarations of gbuffer_position
// (w: camera distance, 0 for the background) and gbuffer_normal.
//
// §6.2.1: at half resolution "the half-resolution depth stencil ... should be downscaled using the
// closest pixel to the camera. However, the depth used in pixel shader clipping should be
// downscaled as the farthest pixel from the camera. As a result, we draw the splatting kernel for
// only pixels that are entirely within the kernel in full resolution", "to remove any irradiance
// bleeding between surfaces". A pixel covers a scale x scale block of G-buffer pixels; of its
// surface pixels (the background receives nothing and is skipped) the nearest and the farthest
// each give a receiver point, where the ray through the pixel's centre meets that pixel's tangent
// plane, and a kernel counts only if it holds both. On one plane the two points are one; across a
// depth edge a kernel on one surface does not hold the other surface's point, so the block takes
// no light (the thesis's jagged edges, left to the filters) where the upsampling would otherwise
// spread one surface's light over the other's pixels. False: the block has no surface pixel.
bool block_receivers(ivec2 pixel, int scale, ivec2 full_size, vec3 camera, vec3 ray,
                     out vec3 near_point, out vec3 far_point) {
  ivec2 first = pixel * scale;
  vec4 near_g = vec4(0.0), far_g = vec4(0.0);
  ivec2 near_pixel = first, far_pixel = first;
  for (int dy = 0; dy < scale; ++dy)
    for (int dx = 0; dx < scale; ++dx) {
      ivec2 p = min(first + ivec2(dx, dy), full_size - 1);
      vec4 g = imageLoad(gbuffer_position, p);
      if (g.w <= 0.0) continue;
      if (near_g.w <= 0.0 || g.w < near_g.w) {
        near_g = g;
        near_pixel = p;
      }
      if (g.w > far_g.w) {
        far_g = g;
        far_pixel = p;
      }
    }
  if (far_g.w <= 0.0) return false;
  near_point = receiver_point(camera, ray, near_g.xyz, imageLoad(gbuffer_normal, near_pixel).xyz);
  far_point = receiver_point(camera, ray, far_g.xyz, imageLoad(gbuffer_normal, far_pixel).xyz);
  return true;
}
