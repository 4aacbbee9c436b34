// collection-points' GPU records and push block, written once for C++ and GLSL (every vec3 followed
// by a 4-byte scalar, so std430 offsets equal the packed C++ ones; technique.cpp static_asserts
// them). GLSL: #include "../cp_layout.h" from shaders/; C++: included in namespace cp.
#ifndef CP_LAYOUT_H
#define CP_LAYOUT_H

#ifdef __cplusplus
#define CP_VEC3 glm::vec3
#define CP_UINT uint32_t
#else
#define CP_VEC3 vec3
#define CP_UINT uint
#endif

// A collection point c_i (Paper V §3): where a pixel's camera path met its first diffuse vertex.
// 64 bytes.
struct CpPoint {
  CP_VEC3 position;    // p, m
  float radius;        // r, m: the gather cylinder's radius (height r / 10)
  CP_VEC3 normal;      // n, unit, facing the arriving camera ray
  CP_UINT material;    // m, Scene::materials index
  CP_VEC3 throughput;  // tau, the camera sub-path's throughput through its S vertices
  CP_UINT pixel;       // y * width + x
  CP_VEC3 pad;
  CP_UINT specular;  // S vertices before it (0: seen directly)
};

// A stored photon as the accumulation reads it. 32 bytes.
struct CpPhoton {
  CP_VEC3 position;
  CP_UINT material;  // Scene::materials index of the surface it landed on
  CP_VEC3 power;     // W (RGB)
  CP_UINT pad;
  CP_VEC3 normal;  // geometric normal, on the side it arrived from
  CP_UINT pad1;
};

#define CP_NONE 0xffffffffu

// Accumulator words per collection point: channel c's low word at 6 cp + c, high word at 6 cp + 3
// + c (fixed64); fixed4_28 uses the low words only.
#define CP_ACCUM_WORDS 6u

// Words of the statistics buffer (uint).
#define CP_STAT_BOXES_TESTED 0u   // 2 words (64-bit): CP boxes the photon walks tested
#define CP_STAT_CONTRIBUTIONS 2u  // 2 words: photon-CP pairs accumulated
#define CP_STAT_NODES 4u          // 2 words: BVH nodes the photon walks popped
#define CP_STAT_SATURATED 6u      // adds clamped at 15 or wrapped (fixed4_28)
#define CP_STAT_TRUNCATED 7u      // walks cut short by the loop budget
#define CP_STAT_REUSED 8u         // CPs that took last frame's contributions
#define CP_STAT_REUSE_TESTED 9u   // 2 words: last frame's CP boxes the reuse walks tested
#define CP_STAT_WORDS 16u

#define CP_ACCUMULATOR_FIXED64 0u
#define CP_ACCUMULATOR_FIXED4_28 1u

// Push block of every pass.
struct CpPush {
  CP_UINT points;   // collection points this frame (pixel slots with cp_update: refit)
  CP_UINT photons;  // photons uploaded
  CP_UINT width;
  CP_UINT height;
  CP_VEC3 units_per_watt;  // fixed64's scale (photonbench/toolkit/fixed_point.h)
  CP_UINT accumulator;     // CP_ACCUMULATOR_*
  CP_VEC3 watts_per_unit;
  CP_UINT temporal;     // 1: blend with last frame's (§3.1)
  float alpha;          // the EMA's weight of the reused value (Eq. 2: 0.8)
  float sigma_scale;    // sigma = sigma_scale r (Eq. 3: 3/4)
  float normal_min;     // n . n' threshold (Eq. 4: 0.9)
  CP_UINT budget;       // loop steps one walk may take
  CP_UINT prev_points;  // last frame's collection points (0: none)
  CP_UINT pad0;
  CP_UINT pad1;
  CP_UINT pad2;
};

#undef CP_VEC3
#undef CP_UINT

#endif  // CP_LAYOUT_H
