// photon-differentials on the CPU: the footprint post-processing, kernel and T_auto exactly as
// the GPU passes compute them (shaders/pd_common.glsl), and the checks of the GPU's BVH
// and query the `verify` test hook runs; the tests call these directly (seed 003, Fabianowski and
// Dingliana 2009; README.md).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "photonbench/photons.h"
#include "photonbench/toolkit/box_bvh.h"

namespace pd {

#include "pd_layout.h"

using pb::toolkit::BvhBox;
using pb::toolkit::BvhNode;

static_assert(sizeof(PdFootprint) == 96 && offsetof(PdFootprint, inverse0) == 16);
static_assert(offsetof(PdFootprint, flux_density) == 64 && offsetof(PdFootprint, incoming) == 80);
static_assert(sizeof(PdPush) == 64);

constexpr float kPi = 3.14159265358979f;

// §4.3 and §7's post-processing of one footprint, parameters as the technique reads them.
struct PostProcess {
  float smoothing = 5;             // s (Table 2: 10 to 60 per scene)
  float smoothing_specular = 5;    // §7: photons with only specular interactions
  float exponent = -0.75f;         // §4.3's nonlinear compression
  bool compress_semiaxis = false;  // factor |Delta dp|^e (the semi-axis) instead of |dp|^e
  float r_max = 0.7f;              // §7's clamp, per semi-axis, m
  float normal_extent = 0.5f;      // h = normal_extent sqrt(|a1| |a2|) (README: the sweep)

  bool operator==(const PostProcess&) const = default;
};

// The photon has had only specular interactions before its hit (L S* D: caustic or direct).
inline bool specular_only(const pb::trace::PhotonRecord& p) {
  uint32_t before = p.bounce >= 32 ? ~0u : ((1u << p.bounce) - 1u);
  return (p.specular_mask & before) == before;
}

// The semi-axes after compression and smoothing, before the clamp: what Table 3 bins.
inline void scaled_semiaxes(const pb::trace::PhotonRecord& p, const PostProcess& pp, glm::vec3& a1,
                            glm::vec3& a2) {
  a1 = p.footprint_u, a2 = p.footprint_v;
  const bool specular = specular_only(p);
  if (!specular && pp.exponent != 0) {
    // §4.3: "Each footprint semiaxis is rescaled by a factor |dp|^(-3/4) with dp the positional
    // differential that was used to generate it"; dp = semi-axis / Delta (the tracer's flags).
    float delta = std::bit_cast<float>(p.flags);
    for (glm::vec3* a : {&a1, &a2}) {
      float length = glm::length(*a);
      float base = pp.compress_semiaxis ? length : (delta > 0 ? length / delta : 0.f);
      if (base > 0) *a *= std::pow(base, pp.exponent);
    }
  }
  const float s = specular ? pp.smoothing_specular : pp.smoothing;
  a1 *= s, a2 *= s;
}

// Clamps a semi-axis to r_max (§7); true when it was longer.
inline bool clamp_semiaxis(glm::vec3& a, float r_max) {
  float length = glm::length(a);
  if (length <= r_max) return false;
  a *= r_max / length;
  return true;
}

// The footprint record and box of photon `index` (shaders/pd_postprocess.comp does the same).
// Returns false for a degenerate footprint (area 0: it contributes nothing and its box is the
// point where it landed).
inline bool make_footprint(const pb::trace::PhotonRecord& p, uint32_t index, const PostProcess& pp,
                           PdFootprint& f, BvhBox& box) {
  glm::vec3 a1, a2;
  scaled_semiaxes(p, pp, a1, a2);
  clamp_semiaxis(a1, pp.r_max);
  clamp_semiaxis(a2, pp.r_max);
  f = PdFootprint{};
  f.position = p.position;
  f.kind = pb::trace::photon_kind(p);
  f.photon = index;
  f.incoming = -p.direction;
  const float l1 = glm::length(a1), l2 = glm::length(a2);
  f.radius_major = std::max(l1, l2), f.radius_minor = std::min(l1, l2);
  const glm::vec3 c3 = pp.normal_extent * std::sqrt(l1 * l2) * p.normal;
  const float cross = glm::length(glm::cross(a1, a2));
  const float det = glm::dot(a1, glm::cross(a2, c3));
  box.lo = box.hi = p.position;
  if (!(cross > 1e-6f * l1 * l2) || !(std::abs(det) > 0) || !(cross > 0)) return false;
  f.area = kPi * cross;
  f.flux_density = p.power / f.area;
  f.inverse0 = glm::cross(a2, c3) / det;
  f.inverse1 = glm::cross(c3, a1) / det;
  f.inverse2 = glm::cross(a1, a2) / det;
  const glm::vec3 half = glm::sqrt(a1 * a1 + a2 * a2 + c3 * c3);
  box.lo = p.position - half, box.hi = p.position + half;
  return true;
}

// Eq. 1's kernel K(q^2), normalised on the unit disk (integral over it: 1 x pi): uniform 1,
// Epanechnikov 2 (1 - q^2). Times flux / (pi |a1 x a2|), a footprint integrates to its flux.
inline float kernel(float q2, bool epanechnikov) {
  if (q2 > 1) return 0;
  return epanechnikov ? 2.f * (1.f - q2) : 1.f;
}

// q^2 of point x in footprint f's ellipsoid coordinates.
inline float ellipsoid_q2(const PdFootprint& f, const glm::vec3& x) {
  const glm::vec3 d = x - f.position;
  const glm::vec3 u{glm::dot(f.inverse0, d), glm::dot(f.inverse1, d), glm::dot(f.inverse2, d)};
  return glm::dot(u, u);
}

// Footprint f's irradiance contribution at x with normal n (W/m^2), as the query adds it.
inline glm::vec3 contribution(const PdFootprint& f, const glm::vec3& x, const glm::vec3& n,
                              bool epanechnikov, bool normal_gate) {
  if (!(f.area > 0)) return glm::vec3(0.f);
  if (normal_gate && glm::dot(f.incoming, n) <= 0) return glm::vec3(0.f);
  return f.flux_density * kernel(ellipsoid_q2(f, x), epanechnikov);
}

// §5.3: T_auto = c sum A_i / A_surfaces, at least 1 (rounded to the nearest whole hit count).
inline uint32_t t_auto(double footprint_area, double surface_area, double c) {
  if (!(surface_area > 0)) return 1;
  double t = std::round(c * footprint_area / surface_area);
  return uint32_t(std::clamp(t, 1.0, 1048576.0));
}

// Table 3's bin of a semi-axis length.
inline uint32_t radius_bin(float radius) {
  return std::min<uint32_t>(PD_RADIUS_BINS - 1, uint32_t(radius / float(PD_RADIUS_BIN_WIDTH)));
}

// The toolkit BVH built over the footprints' boxes, checked (the `verify` hook): internal node
// boxes contain their children's, each node's range is its children's two ranges joined, each run
// leaf's box contains its footprints' boxes (sorted_boxes: in the BVH's item order), and every
// footprint 0 .. count-1 lies in exactly one leaf reached from the root. Returns the number of
// violations; `first` gets the first one described.
inline size_t check_bvh(const std::vector<BvhNode>& nodes, uint32_t runs, uint32_t count,
                        const std::vector<BvhBox>& sorted_boxes, std::string* first = nullptr) {
  size_t bad = 0;
  auto fail = [&](const std::string& what) {
    if (bad++ == 0 && first) *first = what;
  };
  if (count == 0) return runs == 0 ? 0 : 1;
  if (runs == 0 || nodes.size() < size_t(2) * runs - 1) {
    fail("fewer nodes than 2 runs - 1");
    return bad;
  }
  auto contains = [](const glm::vec3& lo, const glm::vec3& hi, const glm::vec3& l,
                     const glm::vec3& h) {
    return glm::all(glm::lessThanEqual(lo, l)) && glm::all(glm::greaterThanEqual(hi, h));
  };
  std::vector<uint32_t> reached(count, 0);
  std::vector<uint32_t> stack{0};
  size_t visited = 0;
  while (!stack.empty()) {
    uint32_t i = stack.back();
    stack.pop_back();
    if (i >= 2 * runs - 1 || ++visited > 2 * size_t(runs)) {
      fail("node index out of range or a cycle");
      return bad;
    }
    const BvhNode& n = nodes[i];
    if (n.first + uint64_t(n.count) > count) fail("node " + std::to_string(i) + " range");
    if (n.left == PB_BVH_NONE) {
      if (i < runs - 1) fail("internal node " + std::to_string(i) + " without children");
      for (uint32_t j = n.first; j < n.first + n.count && j < count; ++j) {
        ++reached[j];
        if (!contains(n.lo, n.hi, sorted_boxes[j].lo, sorted_boxes[j].hi))
          fail("leaf " + std::to_string(i) + " box misses footprint " + std::to_string(j));
      }
      continue;
    }
    for (uint32_t c : {n.left, n.right}) {
      if (c >= 2 * runs - 1) {
        fail("child out of range");
        return bad;
      }
      const BvhNode& k = nodes[c];
      if (!contains(n.lo, n.hi, k.lo, k.hi))
        fail("node " + std::to_string(i) + " box misses child " + std::to_string(c));
      if (k.parent != i) fail("child " + std::to_string(c) + " parent");
      stack.push_back(c);
    }
    const BvhNode &l = nodes[n.left], &r = nodes[n.right];
    if (l.first != n.first || r.first != l.first + l.count || l.count + r.count != n.count)
      fail("node " + std::to_string(i) + " range is not its children's");
  }
  for (uint32_t j = 0; j < count; ++j)
    if (reached[j] != 1) {
      fail("footprint " + std::to_string(j) + " in " + std::to_string(reached[j]) + " leaves");
      break;
    }
  return bad;
}

}  // namespace pd
