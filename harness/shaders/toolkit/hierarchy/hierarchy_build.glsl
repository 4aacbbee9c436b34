// Shared by the cluster-build shaders (hierarchy_*.comp, pb::toolkit::Hierarchy::build): push
// constants, bindings and the order-preserving float <-> uint mapping the leaf bounds are reduced
// with (integer atomics only: the harness's device enables no float atomics).
#define HIER_BUILD
#define HIER_BINDING 0
#include "toolkit/hierarchy.glsl"
layout(binding = HIER_BINDING_COUNT + 0, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = HIER_BINDING_COUNT + 1, rgba32f) readonly uniform image2D gbuffer_normal;

// Mirrors pb::toolkit::Hierarchy's BuildPush (harness/toolkit/src/hierarchy.cpp).
layout(push_constant) uniform HierPush {
  mat4 view;         // world -> view space of this frame's camera
  uint level;        // hierarchy_propagate: the level whose nodes are built from their children
  int normal_scale;  // fixed-point scale of the leaf normal sums (2^30 / pixels per leaf)
  float ln_q_min;    // ln of the depth ratio of a cubical leaf slice (leaf block's angular size)
  uint pad0;
}
hp;

// Monotonic map of floats to uints (negative floats reversed), so atomicMin / atomicMax on the
// words order like the floats.
uint hier_order(float f) {
  uint b = floatBitsToUint(f);
  return (b & 0x80000000u) != 0u ? ~b : (b | 0x80000000u);
}
float hier_unorder(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

bool hier_pixel(out ivec2 pixel) {
  pixel = ivec2(gl_GlobalInvocationID.xy);
  return pixel.x < int(hier.frame.x) && pixel.y < int(hier.frame.y);
}
float hier_view_depth(vec3 world) { return -(hp.view * vec4(world, 1.0)).z; }
