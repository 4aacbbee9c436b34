// Random and quasi-random numbers, warps from [0,1)^2 to directions and points, and the piecewise-
// constant 2D distribution behind emission densities.
//
// Photon tracer: Owen-scrambled Sobol points, padded per bounce (Burley 2020, "Practical Hash-based
// Owen Scrambling", JCGT 9(4)). Why Sobol over Halton: every bounce draws a 4D Sobol point whose 2D
// projections are (0,m,2)-nets, so each bounce's direction is as well stratified as the first,
// whereas Halton's higher prime bases give poor 2D projections deep in a path; hash-based Owen
// scrambling makes any sample index computable on its own (per-photon sample index, so results do
// not depend on the thread count), and a new seed is just a new scramble, which is the per-frame
// seed option.
//
// Reference renderer: independent PCG32 streams, because its error target estimates variance from
// the spread of the samples, which is only valid for independent samples.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "photonbench/trace_math.h"

namespace pb::trace {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// ---- PCG32 (O'Neill 2014), independent streams
// ----------------------------------------------------

class Pcg32 {
 public:
  Pcg32(uint64_t seed, uint64_t stream) {
    inc_ = (stream << 1u) | 1u;
    state_ = 0;
    next_u32();
    state_ += seed;
    next_u32();
  }
  [[gnu::always_inline]] uint32_t next_u32() {
    uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32 - rot) & 31));
  }
  [[gnu::always_inline]] float next_float() {
    return std::min(float(next_u32()) * 0x1p-32f, kOneMinusEpsilon);
  }
  [[gnu::always_inline]] glm::vec2 next_2d() {
    float a = next_float();
    return {a, next_float()};
  }

 private:
  uint64_t state_ = 0, inc_ = 0;
};

// ---- Owen-scrambled Sobol
// -------------------------------------------------------------------------

// The first four Sobol dimensions at `index` (generator matrices from the primitive polynomials
// x+1, x^2+x+1, x^3+x+1 with Joe & Kuo's initial direction numbers; dimension 0 is van der Corput).
uint32_t sobol_u32(uint32_t index, int dimension);

inline uint32_t reverse_bits(uint32_t x) {
  x = __builtin_bswap32(x);  // the bytes in reverse order (one instruction), then each byte's bits
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  return ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
}

// Nested uniform (Owen) scramble by hashing, Burley 2020 §3 (a Laine-Karras style permutation
// applied to the bit-reversed value, so each bit is flipped depending only on the bits above it).
inline uint32_t owen_hash(uint32_t x) {
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) {
  return reverse_bits(owen_hash(reverse_bits(x) + seed));
}

// reverse_bits(sobol_u32(reverse_bits(x), 1)), by four byte lookups: Sobol dimension 1 as
// sobol_group meets it, between the reversals of two Owen scrambles.
struct SobolReversedTables {
  uint32_t t[4][256];
};
extern const SobolReversedTables kSobol1ReversedTables;
inline uint32_t sobol1_reversed(uint32_t x) {
  const auto& t = kSobol1ReversedTables.t;
  return t[0][x & 0xffu] ^ t[1][(x >> 8) & 0xffu] ^ t[2][(x >> 16) & 0xffu] ^ t[3][x >> 24];
}

inline float u32_to_unit(uint32_t x) {
  return std::min(float(x >> 8) * 0x1p-24f, kOneMinusEpsilon);
}

// The scramble seeds of one group of sobol_group: they depend on the seed and the group alone, so
// a tracer that draws the same group for many samples hashes them once.
struct SobolGroupSeeds {
  uint32_t pair[2];       // shuffles the index, per pair of dimensions
  uint32_t digits[2][2];  // scrambles each dimension's value
};
inline SobolGroupSeeds sobol_group_seeds(uint32_t group, uint32_t seed) {
  SobolGroupSeeds s;
  for (uint32_t pair = 0; pair < 2; ++pair) {
    s.pair[pair] = hash_combine(seed, group, pair);
    for (uint32_t d = 0; d < 2; ++d) s.digits[pair][d] = hash_combine(s.pair[pair], d + 1);
  }
  return s;
}
// A 4D point of dimension group `group` (0: emission, 1 + k: interaction k) for sample `index`, as
// two independently shuffled and scrambled copies of Sobol dimensions (0, 1) (Burley 2020 §4,
// padding): Sobol's first two dimensions form a (0,2)-sequence, so each pair (x, y) and (z, w) is a
// (0,m,2)-net over every 2^m-point block, which no other pair of Sobol dimensions guarantees.
//
// Each value is owen_scramble(sobol_u32(owen_scramble(index, pair seed), d), digit seed); as
// owen_scramble(x, s) = R(H(R(x) + s)) with R = reverse_bits (an involution) and H its hash, and
// sobol_u32(., 0) = R, the reversals between the hashes cancel: with h = H(R(index) + pair seed),
// dimension 0 is R(H(R(h) + s0)) and dimension 1 is R(H(sobol1_reversed(h) + s1)), the same bits
// for four reversals and one table lookup fewer a pair (the photon tracer draws one group a
// bounce). Sampling.SobolGroupIsTheScrambledSobolOfItsDefinition checks it against the definition.
inline glm::vec4 sobol_group(uint32_t index, const SobolGroupSeeds& seeds) {
  const uint32_t reversed_index = reverse_bits(index);
  glm::vec4 r;
  for (int pair = 0; pair < 2; ++pair) {
    const uint32_t h = owen_hash(reversed_index + seeds.pair[pair]);
    r[2 * pair] = u32_to_unit(reverse_bits(owen_hash(reverse_bits(h) + seeds.digits[pair][0])));
    r[2 * pair + 1] =
        u32_to_unit(reverse_bits(owen_hash(sobol1_reversed(h) + seeds.digits[pair][1])));
  }
  return r;
}
inline glm::vec4 sobol_group(uint32_t index, uint32_t group, uint32_t seed) {
  return sobol_group(index, sobol_group_seeds(group, seed));
}

// ---- warps
// -----------------------------------------------------------------------------------------

// Uniform on the unit sphere: z = 1 - 2u, phi = 2 pi v (equal-area, the point light's domain).
inline glm::vec3 sphere_from_unit(glm::vec2 u) {
  float z = 1.f - 2.f * u.x;
  float r = std::sqrt(std::max(0.f, 1.f - z * z));
  float phi = 2.f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Uniform in the cone cos(theta) >= cos_max around +z (equal-area, the spot light's domain).
inline glm::vec3 cone_from_unit(glm::vec2 u, float cos_max) {
  float z = 1.f - u.x * (1.f - cos_max);
  float r = std::sqrt(std::max(0.f, 1.f - z * z));
  float phi = 2.f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// cos(x) and sin(x) for |x| <= pi/4, by their Taylor series to x^10 and x^9: the remainders are
// below 2e-9 there, under a float's rounding. The concentric map needs no wider range, and a libm
// sincosf call was a third of a diffuse bounce's sampling cost (perf, cornell-box's photon tracer).
[[gnu::always_inline]] inline glm::vec2 cos_sin_quarter(float x) {
  float x2 = x * x;
  float s = x * (1.f + x2 * (-1.f / 6 + x2 * (1.f / 120 + x2 * (-1.f / 5040 + x2 / 362880))));
  float c = 1.f + x2 * (-1.f / 2 +
                        x2 * (1.f / 24 + x2 * (-1.f / 720 + x2 * (1.f / 40320 - x2 / 3628800))));
  return {c, s};
}

// Shirley-Chiu concentric map to the unit disk (keeps stratification). Written without branches:
// which of |x| and |y| is larger is a coin flip on random input, and a mispredicted branch per
// sample cost more than computing the angle once for either case.
[[gnu::always_inline]] inline glm::vec2 concentric_disk(glm::vec2 u) {
  glm::vec2 o = 2.f * u - 1.f;
  bool x_major = std::abs(o.x) > std::abs(o.y);
  float r = x_major ? o.x : o.y;      // the radius, signed
  float minor = x_major ? o.y : o.x;  // |minor| <= |r|; both are 0 only at the centre
  float phi = (kPi / 4) * (minor / (r != 0 ? r : 1.f));
  glm::vec2 cs = cos_sin_quarter(phi);
  // x-major: theta = phi; otherwise theta = pi/2 - phi, whose cosine and sine swap.
  return r * (x_major ? cs : glm::vec2(cs.y, cs.x));
}

// Cosine-weighted hemisphere around +z; pdf = cos(theta) / pi.
[[gnu::always_inline]] inline glm::vec3 cosine_hemisphere(glm::vec2 u) {
  glm::vec2 d = concentric_disk(u);
  return {d.x, d.y, std::sqrt(std::max(0.f, 1.f - d.x * d.x - d.y * d.y))};
}

// Uniform point in a triangle as barycentrics (b1, b2) (Heitz 2019's low-distortion map would also
// do; the square-root map is simpler and measure-preserving).
inline glm::vec2 triangle_from_unit(glm::vec2 u) {
  float su = std::sqrt(u.x);
  return {1.f - su, u.y * su};
}

// Frame, the orthonormal basis around a unit normal: photonbench/trace_math.h.

// ---- piecewise-constant 2D distribution ---------------------------------------------------------

// Samples [0,1)^2 with density proportional to a width x height grid of non-negative values (a
// marginal over rows v, then a conditional along u). pdf is relative to the uniform measure on the
// square (mean 1).
class Distribution2D {
 public:
  Distribution2D() = default;
  Distribution2D(int width, int height, const std::vector<float>& values);
  bool empty() const { return width_ == 0; }
  // Continuous sample: the texel is chosen by its value, the position inside it is uniform.
  glm::vec2 sample(glm::vec2 u, float* pdf) const;
  float pdf(glm::vec2 uv) const;
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_ = 0, height_ = 0;
  std::vector<float> values_;   // normalised to mean 1
  std::vector<float> row_cdf_;  // height + 1
  std::vector<float> col_cdf_;  // height * (width + 1)
};

}  // namespace pb::trace
