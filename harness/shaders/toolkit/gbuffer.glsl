// The shared G-buffer as toolkit shaders read it (pb::GBuffer, photonbench/context.h): define
// PB_GBUFFER_BINDING to the first of three consecutive storage-image bindings, include this, and
// bind pb::toolkit::gbuffer_resources() there.
//   + 0 gbuffer_position  world xyz, w = distance to the camera (0: background)
//   + 1 gbuffer_normal    world shading normal facing the camera, w = material index
//   + 2 gbuffer_albedo    diffuse albedo rgb, w = material type (PB_MATERIAL_*)
#ifndef PB_TOOLKIT_GBUFFER_GLSL
#define PB_TOOLKIT_GBUFFER_GLSL

#include "photonbench/scene_layout.h"

#ifndef PB_GBUFFER_BINDING
#error "define PB_GBUFFER_BINDING (the first of the G-buffer's three bindings) first"
#endif

layout(binding = PB_GBUFFER_BINDING + 0, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = PB_GBUFFER_BINDING + 1, rgba32f) readonly uniform image2D gbuffer_normal;
layout(binding = PB_GBUFFER_BINDING + 2, rgba32f) readonly uniform image2D gbuffer_albedo;

bool pb_in_frame(ivec2 pixel, uvec2 size) {
  return pixel.x >= 0 && pixel.y >= 0 && pixel.x < int(size.x) && pixel.y < int(size.y);
}

// Diffuse (and emissive, which the tracer treats as diffuse) materials: the surfaces photons are
// stored on and the Lambertian estimates light (path class C D (D|S)* D (D|S)* L).
bool pb_material_lit(float type_as_float) {
  int type = int(type_as_float);
  return type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE;
}

// A pixel's view sample when it has geometry of a lit material: world position, normal and albedo
// (the normal is read only then).
bool pb_lit_sample(ivec2 pixel, out vec3 position, out vec3 normal, out vec3 albedo) {
  vec4 p = imageLoad(gbuffer_position, pixel);
  vec4 a = imageLoad(gbuffer_albedo, pixel);
  position = p.xyz;
  albedo = a.rgb;
  normal = vec3(0.0);
  if (p.w <= 0.0 || !pb_material_lit(a.w)) return false;
  normal = imageLoad(gbuffer_normal, pixel).xyz;
  return true;
}

#endif
