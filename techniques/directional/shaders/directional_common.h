// What every directional pass reads besides the hierarchy: the push constants (one block for every
// pass, 112 of the 128 bytes Vulkan guarantees) and the bucket layout.
//
// Bucket layout (Paper I §4.7, §5.2: "24 floats per node"): node cid c (the hierarchy's compact
// node id, levels 0 .. accumulation level) owns words [24 c, 24 c + 24) of flux[]: octant o's RGB
// flux at 24 c + 3 o + channel, in watts, in fixed point: the harness's device enables no float
// atomics, so each deposit adds round(Phi * scale) with one integer atomicAdd. scale = 4e9 / (the
// largest channel's total flux of the frame's photons): no bucket can receive more than every
// photon's whole flux once, so a word never overflows (4e9 + N/2 rounding units < 2^32 for N < 5e8
// photons), and a photon's flux is resolved to ~N / 4e9 of itself. Integer sums are also
// order-independent, so the buckets are the same bits on every run.
#ifndef DIRECTIONAL_COMMON_H
#define DIRECTIONAL_COMMON_H

#define DIR_FLAG_DEPOSIT_PAPER 1u  // intersected accumulation-level nodes get the whole flux
#define DIR_FLAG_WEIGHT_CLIP 2u    // octant weights: solid-angle share above the tangent plane
#define DIR_FLAG_DEBUG_NORMAL 4u   // test hook: irradiance = |world normal|

// Stats words (host-visible): [0..1] bucket deposits (lo, hi), [2] photons whose traversal ran past
// max_visits, [3] photons that deposited nothing (no occupied node met, or zero coverage).
#define DIR_STAT_DEPOSITS 0
#define DIR_STAT_OVERFLOWS 2
#define DIR_STAT_MISSED 3
#define DIR_STAT_WORDS 8

// Fixed-point scale of the sample-position sums of leaf_counts.comp (units of the child's AABB).
#define DIR_CENTROID_SCALE 4096.0

struct DirParams {
  mat4 view;             // world -> view (right-handed, the camera looks along -z)
  vec4 radius;           // x r (m), y 1 / (pi r^2), z flux fixed-point scale, w 1 / scale
  uvec4 counts;          // x photons, y stop level (deposits at and above it), z DIR_FLAG_*,
                         // w max visits per photon
  uvec4 size;            // x width, y height (pixels)
};

// An exact 64-bit counter from two 32-bit words: the low word's carry goes to the high word.
#define DIR_ADD64(words, at, value)                             \
  {                                                             \
    uint v_ = (value);                                          \
    if (v_ != 0u) {                                             \
      uint old_ = atomicAdd(words[at], v_);                     \
      if (old_ + v_ < old_) atomicAdd(words[(at) + 1], 1u);     \
    }                                                           \
  }

#endif
