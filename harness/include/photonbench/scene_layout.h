// GPU data layouts shared by C++ and GLSL: written once, included by both (GLSL: `#include
// "photonbench/scene_layout.h"`). std430; every member a 16-byte vector so C++ and GLSL agree
// without padding rules. The C++ side checks sizes with static_asserts in
// harness/src/gpu/shared_passes.cpp.
#ifndef PB_SCENE_LAYOUT_H
#define PB_SCENE_LAYOUT_H

#ifdef __cplusplus
#include <glm/glm.hpp>
namespace pb::layout {
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
#endif

// Material types, as pb::scene::MaterialType.
#define PB_MATERIAL_DIFFUSE 0
#define PB_MATERIAL_MIRROR 1
#define PB_MATERIAL_DIELECTRIC 2
#define PB_MATERIAL_ROUGH_CONDUCTOR 3
#define PB_MATERIAL_ROUGH_DIELECTRIC 4
#define PB_MATERIAL_EMISSIVE 5

// Light types, as pb::scene::LightType.
#define PB_LIGHT_POINT 0
#define PB_LIGHT_SPOT 1
#define PB_LIGHT_DIRECTIONAL 2
#define PB_LIGHT_QUAD 3
#define PB_LIGHT_DISC 4

struct GpuMaterial {
  vec4 albedo_type;         // rgb diffuse albedo, w = PB_MATERIAL_* as float
  vec4 emission_roughness;  // rgb emitted radiance, w = GGX alpha
  vec4 specular_ior;        // rgb mirror tint / conductor F0, w = IOR
};

struct GpuLight {
  vec4 position_type;        // xyz position (quad: corner, disc: centre), w = PB_LIGHT_*
  vec4 radiant;              // rgb: I (W/sr), E (W/m^2) or L (W/m^2/sr) by type
  vec4 direction_cos_outer;  // xyz spot axis / propagation direction, w = cos(outer half-angle)
  vec4 edge_u_cos_inner;     // xyz quad edge u (disc: a radius), w = cos(inner half-angle)
  // xyz quad edge v (disc: the radius cross(normal, edge u)), w = first shadow tile (6 faces, or 1
  // for directional)
  vec4 edge_v_first_tile;
};

struct GpuFrame {
  mat4 view_projection;
  mat4 inverse_view_projection;
  vec4 camera_position;  // xyz, w = vertical fov (radians)
  uvec4 size_lights;     // x width, y height, z light count, w shadow tile size (texels)
  uvec4 shadow_atlas;    // x atlas width, y atlas height, z tiles per row, w total tiles
};

// The scene's triangles in world space, in one scene-wide numbering: object o's mesh triangle t is
// triangle first_triangle(o) + t, objects in scene order (pb::SceneTriangles). The photon records'
// `triangle` and draw_scene's triangle target use the same numbering.
#define PB_NO_TRIANGLE 0xffffffffu  // a triangle target's texel where nothing was drawn

struct GpuSceneVertex {
  vec4 position;  // world xyz, w = 1
  vec4 normal;    // world unit shading normal xyz, w = 1; (0, 0, 0, 0) where the mesh has none
};

struct GpuSceneTriangle {
  uvec4 vertices_object;  // xyz: indices into GpuSceneVertex[] (scene-wide), w = object index
  vec4 normal_area;       // xyz: unit geometric normal (p1 - p0) x (p2 - p0), w = area (m^2)
  uvec4 material_local;   // x: material index, y: the triangle's index in its object's mesh, zw 0
};

#ifdef __cplusplus
}  // namespace pb::layout
#endif
#endif
