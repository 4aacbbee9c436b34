#version 460
// The constant ambient term: a Lambertian surface under uniform incident radiance L_a reflects
// L_o = (albedo / pi) * integral over the hemisphere of L_a cos(theta) d(omega) = albedo * L_a.
// Written for lit (diffuse) surfaces only, as the indirect estimate shade() adds to direct light.
#define PB_GBUFFER_BINDING 0
#include "toolkit/gbuffer.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 3, rgba32f) writeonly uniform image2D indirect_out;
layout(push_constant) uniform Push {
  vec4 ambient_radiance;  // rgb, W / (sr m^2)
  uvec2 size;
}
push;
void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (!pb_in_frame(pixel, push.size)) return;
  vec4 albedo = imageLoad(gbuffer_albedo, pixel);
  bool lit = imageLoad(gbuffer_position, pixel).w > 0.0 && pb_material_lit(albedo.w);
  imageStore(indirect_out, pixel, vec4(lit ? albedo.rgb * push.ambient_radiance.rgb : vec3(0), 1));
}
