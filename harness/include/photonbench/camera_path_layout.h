// The camera path record, written once for C++ and GLSL: the camera-path tracer fills an array of
// these on the CPU, one per pixel in pixel order, and a technique uploads it as-is into a std430
// storage buffer (trace_and_upload_camera_paths, photonbench/context.h). Every vec3 is followed by
// a 4-byte scalar, so the std430 offsets equal the packed C++ offsets; camera_paths.h
// static_asserts the size and each offset.
//
// GLSL:  #include "photonbench/camera_path_layout.h"   then
//        layout(std430, binding = 0) readonly buffer CameraPaths { CameraPathRecord paths[]; };
// C++:   photonbench/camera_paths.h includes this inside namespace pb::trace.
#ifndef PB_CAMERA_PATH_LAYOUT_H
#define PB_CAMERA_PATH_LAYOUT_H

#ifdef __cplusplus
#define PB_VEC3 glm::vec3
#define PB_UINT uint32_t
#define PB_FLOAT float
#else
#define PB_VEC3 vec3
#define PB_UINT uint
#define PB_FLOAT float
#endif

// One pixel's camera path from the eye through its specular (S) vertices to its first diffuse (D)
// vertex. 80 bytes.
struct CameraPathRecord {
  PB_VEC3 position;           // the last vertex: the first diffuse hit, or where the path ended
  PB_UINT pixel;              // y * width + x
  PB_VEC3 normal;             // unit shading normal at `position`, facing the arriving ray
  PB_UINT material;           // Scene::materials index at `position` (~0u: nothing hit)
  PB_VEC3 throughput;         // product of the S vertices' f |cos| / pdf (1 with no S vertex)
  PB_FLOAT cone_width;        // the pixel's ray-cone width at `position`, metres
  PB_VEC3 segment_origin;     // the last segment: from the last S vertex, or the eye
  PB_FLOAT segment_length;    // to `position`, metres (0 when the path escaped)
  PB_VEC3 segment_direction;  // unit
  PB_UINT flags;              // bits 0-7: S vertices passed; PB_CAMERA_PATH_* below
};

// Flags above the S-vertex count: a path with PB_CAMERA_PATH_NO_DIFFUSE ended without a diffuse
// hit, and the bit beside it says why (neither: absorbed by a luminaire's geometry, or no sampled
// direction left the surface).
#define PB_CAMERA_PATH_SPECULAR_MASK 0xffu
#define PB_CAMERA_PATH_NO_DIFFUSE 0x100u
#define PB_CAMERA_PATH_ESCAPED 0x200u       // the last segment left the scene
#define PB_CAMERA_PATH_BOUNCE_LIMIT 0x400u  // max_bounces surface hits, the last one specular

#undef PB_VEC3
#undef PB_UINT
#undef PB_FLOAT

#endif  // PB_CAMERA_PATH_LAYOUT_H
