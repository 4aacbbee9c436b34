// The photon record, written once for C++ and GLSL: the photon tracer fills an array of these on
// the CPU and a technique uploads it as-is into a std430 storage buffer. Every vec3 is followed by
// a 4-byte scalar, so the std430 offsets (vec3 aligned to 16) equal the packed C++ offsets
// (glm::vec3 is 12 bytes); photons.h static_asserts the size and each offset.
//
// GLSL:  #include "photonbench/photon_layout.h"   then
//        layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
// C++:   photonbench/photons.h includes this inside namespace pb::trace.
#ifndef PB_PHOTON_LAYOUT_H
#define PB_PHOTON_LAYOUT_H

#ifdef __cplusplus
#define PB_VEC3 glm::vec3
#define PB_UINT uint32_t
#else
#define PB_VEC3 vec3
#define PB_UINT uint
#endif

// One photon: the state of a light path arriving at a surface where the tracer was asked to store
// it. 96 bytes.
struct PhotonRecord {
  PB_VEC3 position;       // world position of the hit, metres
  PB_UINT triangle;       // scene-wide index of the triangle hit (photonbench/scene_layout.h's
                          // numbering; its object: pb::SceneTriangles::object(triangle))
  PB_VEC3 power;          // flux carried, W (RGB); summed over the photons of one trace it
                          // estimates the power arriving at the stored surfaces
  PB_UINT path;           // index of the light path this photon belongs to (its sample index)
  PB_VEC3 direction;      // unit direction of travel of the arriving photon (towards the surface);
                          // the incident direction of the usual estimators is -direction
  PB_UINT bounce;         // surface interactions before this one: 0 = the first hit from the light
  PB_VEC3 normal;         // unit geometric normal at the hit, on the side the photon arrived from
  PB_UINT specular_mask;  // bit i set: interaction i of the path (0 = first hit) was
                          // specular/glossy (S); clear: diffuse (D). Bits 0..bounce-1 are the path
                          // before this hit, bit `bounce` is this (diffuse) hit. See
                          // pb::trace::photon_kind.
  PB_VEC3 footprint_u;    // ray-differential footprint: the displacement of the hit point when the
                          // path's first emission parameter moves by one photon spacing
                          // (parallelogram edge, m); zero unless the trace asks for footprints
  PB_UINT light;          // index of the emitting light (scene lights, then emissive objects)
  PB_VEC3 footprint_v;    // the same for the second emission parameter; |u x v| ~ area per photon,
                          // m^2
  PB_UINT flags;          // the technique's own bits, set by its vertex policy
                          // (pb::trace::VertexDecision::photon_flags); 0 without one
};

#undef PB_VEC3
#undef PB_UINT

#endif  // PB_PHOTON_LAYOUT_H
