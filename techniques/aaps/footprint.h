// AAPS's splat footprint and the per-photon inputs of the task-buffer update (seed 004 §1.6-1.7,
// §3.1.5), apart from the plugin so that the tests check the very code it runs: the ellipse's
// principal semi-axes from the photon differentials, the energy fraction of a photon in its texel,
// and the variance term of the density feedback. Header-only, as task_buffer.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

namespace aaps {

// The principal semi-axes of the ellipse with conjugate semi-diameters a and b (the ellipse
// P + cos t a + sin t b), from the eigen-decomposition of their 2x2 Gram matrix; the minor one is
// grown to major / max_anisotropy where the ratio exceeds it (§3.1.2: anisotropy "limited to a
// maximum value by reshaping"; the rule is unspecified, growing the minor axis keeps the splat's
// extent along the caustic). Without the clamp the area pi |major| |minor| equals pi |a x b|.
inline void principal_axes(const glm::vec3& a, const glm::vec3& b, float max_anisotropy,
                           glm::vec3& major, glm::vec3& minor) {
  float aa = glm::dot(a, a), ab = glm::dot(a, b), bb = glm::dot(b, b);
  float mean = 0.5f * (aa + bb), diff = 0.5f * (aa - bb);
  float root = std::sqrt(diff * diff + ab * ab);
  float l1 = mean + root, l2 = std::max(0.f, mean - root);
  // Eigenvector of l1 in the (a, b) basis.
  glm::vec2 e = std::abs(ab) > 1e-30f ? glm::vec2(ab, l1 - aa)
                                      : (aa >= bb ? glm::vec2(1, 0) : glm::vec2(0, 1));
  glm::vec3 d1 = e.x * a + e.y * b;
  float len1 = glm::length(d1);
  glm::vec3 axis1 = len1 > 0 ? d1 / len1 : glm::vec3(0.f);
  glm::vec3 normal = glm::cross(a, b);
  glm::vec3 axis2 =
      glm::length(normal) > 0 ? glm::normalize(glm::cross(normal, axis1)) : glm::vec3(0.f);
  float major_len = std::sqrt(l1), minor_len = std::sqrt(l2);
  minor_len = std::max(minor_len, major_len / max_anisotropy);
  major = axis1 * major_len;
  minor = axis2 * minor_len;
}

// A photon's share of its texel's energy (§3.1.5: "within one density texel, the fractions sum to
// one"): its power over the power the texel's photons left the light with. The texel's power is
// the tracer's (GridEmission::power_per_texel), not the light's power / texels: a spot light's
// texels do not carry equal power (its falloff), and a photon carries the uniform cone's power
// times the falloff in its direction.
inline float energy_fraction(const glm::vec3& power, float power_per_texel) {
  return power_per_texel > 0 ? (power.x + power.y + power.z) / 3.f / power_per_texel : 0.f;
}

// What the variance pass needs of an accepted photon.
struct VarianceInput {
  glm::vec3 position;
  uint32_t texel;
  float energy_fraction;
};

// §1.10a / §3.1.5: each photon's caustic value at its centre pixel now (view-projection `now_vp`,
// image `now`) and at its pixel in the previous frame (`prev_vp`, `prev`), their relative
// difference |c - q| / max(c, q) in [0, 1] (the thesis leaves the metric open) weighted by the
// photon's energy fraction, summed into its texel of `variance` (an energy-weighted mean, since the
// fractions sum to one). "If a difference value for a photon cannot be found ... a value of 0"
// (outside either frame, or black in both).
inline void accumulate_variance(const std::vector<VarianceInput>& photons, const float* now,
                                const glm::mat4& now_vp, const std::vector<float>& prev,
                                const glm::mat4& prev_vp, uint32_t width, uint32_t height,
                                std::vector<float>& variance) {
  if (prev.size() != size_t(width) * height) return;  // no previous frame
  auto pixel = [&](const glm::mat4& vp, const glm::vec3& p, int& x, int& y) {
    glm::vec4 c = vp * glm::vec4(p, 1.f);
    if (c.w <= 0) return false;
    x = int(std::floor((c.x / c.w * 0.5f + 0.5f) * float(width)));
    y = int(std::floor((c.y / c.w * 0.5f + 0.5f) * float(height)));
    return x >= 0 && y >= 0 && x < int(width) && y < int(height);
  };
  for (const VarianceInput& a : photons) {
    int x, y, px, py;
    if (!pixel(now_vp, a.position, x, y) || !pixel(prev_vp, a.position, px, py)) continue;
    float c = now[size_t(y) * width + x], q = prev[size_t(py) * width + px];
    float scale = std::max(c, q);
    if (scale > 0) variance[a.texel] += a.energy_fraction * std::abs(c - q) / scale;
  }
}

}  // namespace aaps
