#version 460
// Pass "filter" (Ch. 12 steps 5-6): over the active cells only, Eq. 12.1's (2k + 1)^2 filter of
// the counts (8-bit: each saturated at 255), normalised by its weights' sum and carrying the
// photons' mean flux, over Eq. 12.2's pixel area; radiance = albedo / pi * irradiance.
#include "sc_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  uint cell = active_cells[gl_WorkGroupID.y];
  uvec2 cell_xy = uvec2(cell % push.grid, cell / push.grid);
  uvec2 tile =
      uvec2(gl_WorkGroupID.x % push.tiles_per_cell_x, gl_WorkGroupID.x / push.tiles_per_cell_x);
  uvec2 offset = tile * 8u + gl_LocalInvocationID.xy;
  if (offset.x >= push.cell_width || offset.y >= push.cell_height) return;
  ivec2 pixel = ivec2(cell_xy * uvec2(push.cell_width, push.cell_height) + offset);
  if (pixel.x >= int(push.width) || pixel.y >= int(push.height)) return;
  vec4 g = imageLoad(g_position, pixel);
  vec4 albedo = imageLoad(g_albedo, pixel);  // w: the material type
  vec3 radiance = vec3(0.0);
  // Caustic photons are stored on diffuse surfaces only: other pixels get none.
  if (g.w > 0.0 && uint(albedo.w + 0.5) == PB_MATERIAL_DIFFUSE) {
    float weighted = 0.0;
    for (int j = -push.k; j <= push.k; ++j)
      for (int i = -push.k; i <= push.k; ++i) {
        ivec2 q = pixel + ivec2(i, j);
        if (q.x < 0 || q.y < 0 || q.x >= int(push.width) || q.y >= int(push.height)) continue;
        weighted += sc_weight(i, j, push.k) *
                    sc_count(counts[uint(q.y) * push.width + uint(q.x)], push.count_precision);
      }
    if (weighted > 0.0) {
      vec3 normal = imageLoad(g_normal, pixel).xyz;
      vec3 to_eye = frame.camera_position.xyz - g.xyz;
      float cos_ne = dot(normal, normalize(to_eye));
      float depth = dot(-to_eye, push.view_forward);  // d of Eq. 12.5: along the view axis
      float area =
          sc_pixel_area(push.area_scaling, depth, cos_ne, push.pixel_tan_x, push.pixel_tan_y);
      for (int c = 0; c < 3; ++c)
        radiance[c] =
            albedo[c] / float(SC_PI) * sc_irradiance(weighted, push.weight_sum, push.flux[c], area);
    }
  }
  imageStore(caustics, pixel, vec4(radiance, 1.0));
}
