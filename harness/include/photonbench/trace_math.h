// Small math the photon tracer and a technique's tracer policies share: the integer hashes the
// tracer seeds its sequences with (an emission sampler's own deterministic choices hash the same
// way), and the orthonormal frame its BSDF sampling measures directions in (a footprint rule that
// works in a surface's frame sees the directions as the tracer sampled them).
#pragma once

#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>

namespace pb::trace {

inline uint32_t hash_u32(uint32_t x) {  // a 32-bit integer finaliser (lowbias32 style)
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}
inline uint32_t hash_combine(uint32_t a, uint32_t b) {
  return hash_u32(a ^ (hash_u32(b) + 0x9e3779b9u + (a << 6) + (a >> 2)));
}
inline uint32_t hash_combine(uint32_t a, uint32_t b, uint32_t c) {
  return hash_combine(hash_combine(a, b), c);
}

// An orthonormal frame around a unit normal n (z): Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited".
struct Frame {
  glm::vec3 t, b, n;
  Frame() = default;
  explicit Frame(const glm::vec3& normal) : n(normal) {
    float sign = std::copysign(1.f, n.z);
    float a = -1.f / (sign + n.z);
    float bb = n.x * n.y * a;
    t = {1.f + sign * n.x * n.x * a, sign * bb, -sign * n.x};
    b = {bb, sign + n.y * n.y * a, -n.y};
  }
  glm::vec3 to_local(const glm::vec3& v) const {
    return {glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)};
  }
  glm::vec3 to_world(const glm::vec3& v) const { return v.x * t + v.y * b + v.z * n; }
};

}  // namespace pb::trace
