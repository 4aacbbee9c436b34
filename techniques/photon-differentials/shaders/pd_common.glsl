// photon-differentials' one binding list and push block (every pass declares all of them, so the
// C++ side binds one resource list), and the helpers footprint.h mirrors on the CPU.
#include "../pd_layout.h"
#include "photonbench/photon_layout.h"
#include "photonbench/scene_layout.h"
#include "photonbench/toolkit/limits.h"

layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 1) buffer Footprints { PdFootprint footprints[]; };     // photon order
layout(std430, binding = 2) buffer Boxes { PdBox boxes[]; };                     // photon order
layout(std430, binding = 3) buffer Sorted { PdFootprint sorted_footprints[]; };  // Morton order
layout(std430, binding = 4) buffer Keys { uint keys[]; };      // Morton codes (sorted in place)
layout(std430, binding = 5) buffer Values { uint values[]; };  // photon index of each key
layout(std430, binding = 6) buffer Heads { uint heads[]; };    // 1 where a run of a code starts
layout(std430, binding = 7) buffer RunIndex { uint run_index[]; };      // exclusive scan of heads
layout(std430, binding = 8) buffer UniqueKeys { uint unique_keys[]; };  // code of each run
layout(std430, binding = 9) coherent buffer Nodes { PdNode nodes[]; };
layout(std430, binding = 10) coherent buffer Control { uint control[]; };
layout(std430, binding = 11) buffer Partials { float partials[]; };  // footprint area per group
#define PB_GBUFFER_BINDING 12
#include "toolkit/gbuffer.glsl"
layout(binding = 15, rgba32f) writeonly uniform image2D radiance;

layout(push_constant) uniform Push { PdPush push; };

#define PD_PI 3.14159265358979

// Floats as uints whose unsigned order is the floats' order (for atomicMin / atomicMax).
uint pd_ordered(float f) {
  uint b = floatBitsToUint(f);
  return (b & 0x80000000u) != 0u ? ~b : (b | 0x80000000u);
}
float pd_unordered(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

// footprint.h's expand_bits / morton30.
uint pd_expand_bits(uint v) {
  v = (v * 0x00010001u) & 0xFF0000FFu;
  v = (v * 0x00000101u) & 0x0F00F00Fu;
  v = (v * 0x00000011u) & 0xC30C30C3u;
  v = (v * 0x00000005u) & 0x49249249u;
  return v;
}
uint pd_morton30(vec3 unit) {
  uvec3 q = uvec3(clamp(unit * 1024.0, vec3(0.0), vec3(1023.0)));
  return pd_expand_bits(q.x) * 4u + pd_expand_bits(q.y) * 2u + pd_expand_bits(q.z);
}
