// rsm-photons: the CPU halves of the technique (seed 000), kept apart from the Vulkan code so that
// the tests call them on hand-built inputs: the probability map of a light's reflective shadow map
// (§5.2, Eq. 4.9), the 2D Haar wavelet transform and the hierarchical warping of Hammersley points
// (§5.3), the splat kernel (§6.1, Eq. 6.1-6.6), and the filters (§7: temporal with geometric
// weights, edge-avoiding a-trous with variance-clipped details, shading with the mean light
// direction). README.md gives every constant the thesis leaves open.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

namespace rsm {

inline constexpr float kPi = 3.14159265358979323846f;

inline float max3(const glm::vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }
inline float mean3(const glm::vec3& v) { return (v.x + v.y + v.z) / 3.f; }

// ---- The reflective shadow map and its probability map (§5.1-5.2) ----------------------------

// One RSM texel: the first surface the light sees through it.
struct RsmTexel {
  bool sampled = false;  // a ray of the RSM pass landed in this texel
  bool hit = false;      // ... and hit a surface (false: it left the scene)
  float distance = 0;    // from the light's emission point, m (the texel's depth)
  glm::vec3 position{0.f}, normal{0.f};
  glm::vec3 incident{0.f};     // power arriving through the texel, W (light colour x falloff)
  glm::vec3 reflectance{0.f};  // what the surface sends on per channel (diffuse: its albedo)
};

// Eq. 4.9 (Jensen's multichannel Russian roulette): the one Bernoulli trial's success probability
// p = max_c(rho_c Phi_c) / max_c(Phi_c).
inline float survival(const glm::vec3& reflectance, const glm::vec3& incident) {
  const float m = max3(incident);
  if (!(m > 0)) return 0.f;
  return std::clamp(max3(reflectance * incident) / m, 0.f, 1.f);
}

// §5.2: per texel, p of Eq. 4.9 times the light's falloff (the incident power's mean over RGB:
// the RSM pass emits uniformly over the emission domain, so a texel's power is the light's power
// per texel times the falloff), zero outside [photon_near, photon_far] and where the ray met
// nothing. Not normalised (§5.2). A texel no RSM ray landed in (several lights share the pass's
// paths by power, so a dim light's net has holes) gets the mean of the others: zero there would
// drop its share of the light (EmissionDensity, photons.h).
inline std::vector<float> probability_map(const std::vector<RsmTexel>& texels, float photon_near,
                                          float photon_far) {
  std::vector<float> p(texels.size(), 0.f);
  double sum = 0;
  size_t sampled = 0;
  for (size_t i = 0; i < texels.size(); ++i) {
    const RsmTexel& t = texels[i];
    if (!t.sampled) continue;
    ++sampled;
    if (!t.hit || t.distance < photon_near || t.distance > photon_far) continue;
    p[i] = survival(t.reflectance, t.incident) * mean3(t.incident);
    sum += p[i];
  }
  const float fill = sampled > 0 ? float(sum / double(sampled)) : 0.f;
  for (size_t i = 0; i < texels.size(); ++i)
    if (!texels[i].sampled) p[i] = fill;
  return p;
}

// ---- The 2D Haar wavelet transform and hierarchical warping (§5.3) ---------------------------

// The Haar transform of a square map of power-of-two side, down to one scaling coefficient: level
// 0 is the map itself, level k has side >> k; each level's scaling coefficients are the means of
// their 2x2 children (low pass) and each quad also has three detail coefficients (high pass:
// horizontal, vertical, diagonal). Warping needs only the scaling coefficients (the child
// probabilities of Eq. 5.1 are their ratios); the details make the transform invertible.
class HaarPyramid {
 public:
  HaarPyramid() = default;
  HaarPyramid(const std::vector<float>& map, uint32_t side) { build(map, side); }

  // `side` a power of two, at least 1.
  void build(const std::vector<float>& map, uint32_t side) {
    side_ = side;
    scaling_.assign(1, map);
    details_.clear();
    for (uint32_t s = side; s > 1; s /= 2) {
      const std::vector<float>& fine = scaling_.back();
      const uint32_t half = s / 2;
      std::vector<float> coarse(size_t(half) * half);
      std::vector<glm::vec3> detail(size_t(half) * half);
      for (uint32_t y = 0; y < half; ++y)
        for (uint32_t x = 0; x < half; ++x) {
          const float a = fine[(2 * y) * s + 2 * x], b = fine[(2 * y) * s + 2 * x + 1];
          const float c = fine[(2 * y + 1) * s + 2 * x], d = fine[(2 * y + 1) * s + 2 * x + 1];
          coarse[y * half + x] = (a + b + c + d) / 4;
          detail[y * half + x] = {(a - b + c - d) / 4, (a + b - c - d) / 4, (a - b - c + d) / 4};
        }
      scaling_.push_back(std::move(coarse));
      details_.push_back(std::move(detail));
    }
  }
  uint32_t side() const { return side_; }
  uint32_t levels() const { return uint32_t(scaling_.size()); }
  // P0 of §5.3.3: the mean of the map, the coarsest scaling coefficient.
  float mean() const { return scaling_.empty() ? 0.f : scaling_.back()[0]; }
  const std::vector<float>& scaling(uint32_t level) const { return scaling_[level]; }

  // The inverse transform (a test of the forward one): the map rebuilt from the coarsest scaling
  // coefficient and every level's details.
  std::vector<float> reconstruct() const {
    std::vector<float> s = {mean()};
    for (size_t l = details_.size(); l-- > 0;) {
      const uint32_t half = side_ >> (l + 1), full = half * 2;
      std::vector<float> fine(size_t(full) * full);
      for (uint32_t y = 0; y < half; ++y)
        for (uint32_t x = 0; x < half; ++x) {
          const float m = s[y * half + x];
          const glm::vec3 d = details_[l][y * half + x];
          fine[(2 * y) * full + 2 * x] = m + d.x + d.y + d.z;
          fine[(2 * y) * full + 2 * x + 1] = m - d.x + d.y - d.z;
          fine[(2 * y + 1) * full + 2 * x] = m + d.x - d.y - d.z;
          fine[(2 * y + 1) * full + 2 * x + 1] = m - d.x - d.y + d.z;
        }
      s = std::move(fine);
    }
    return s;
  }

  struct Sample {
    uint32_t texel = 0;  // row-major in the finest level
    glm::vec2 uv{0.f};   // the point in [0,1)^2 of the whole map
    float density = 0;   // its pdf over [0,1)^2: P(texel) / mean(P)
  };
  // Which side of [0, 1) split at p the coordinate u falls on (0: below p), and u rescaled to
  // [0, 1) within that side.
  static uint32_t split(float& u, float p) {
    if (u < p) {
      u /= p;
      return 0;
    }
    u = (u - p) / (1 - p);
    return 1;
  }

  // §5.3.2: from the coarsest quad to the finest, the point is warped first horizontally (left or
  // right column by the columns' sums), then vertically (top or bottom child within the column),
  // and rescaled into the chosen child. Measure-preserving: uniform points come out distributed
  // as the map (piecewise constant).
  Sample warp(glm::vec2 u) const {
    uint32_t x = 0, y = 0;
    for (uint32_t level = levels() - 1; level-- > 0;) {
      const std::vector<float>& fine = scaling_[level];
      const uint32_t s = side_ >> level;
      const float a = fine[(2 * y) * s + 2 * x], b = fine[(2 * y) * s + 2 * x + 1];
      const float c = fine[(2 * y + 1) * s + 2 * x], d = fine[(2 * y + 1) * s + 2 * x + 1];
      const float total = a + b + c + d;
      const float left = total > 0 ? (a + c) / total : 0.5f;
      const uint32_t col = split(u.x, left);
      const float top_sum = col == 0 ? a : b, column = col == 0 ? a + c : b + d;
      const uint32_t row = split(u.y, column > 0 ? top_sum / column : 0.5f);
      u = glm::clamp(u, glm::vec2(0.f), glm::vec2(0x1.fffffep-1f));
      x = 2 * x + col, y = 2 * y + row;
    }
    Sample out;
    out.texel = y * side_ + x;
    out.uv = (glm::vec2(float(x), float(y)) + u) / float(side_);
    const float m = mean();
    out.density = m > 0 ? scaling_[0][out.texel] / m : 0.f;
    return out;
  }

 private:
  uint32_t side_ = 0;
  std::vector<std::vector<float>> scaling_;      // [level][texel]
  std::vector<std::vector<glm::vec3>> details_;  // [level] (between level l and l + 1)
};

// Point i of an n-point Hammersley set (§5.3.2: low discrepancy), rotated by `offset` modulo 1
// (a Cranley-Patterson shift: a new subset of the strata each frame, §4.2).
inline glm::vec2 hammersley(uint32_t i, uint32_t n, glm::vec2 offset = glm::vec2(0.f)) {
  uint32_t bits = i;
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
  glm::vec2 p{(float(i) + 0.5f) / float(n), float(bits) * 0x1p-32f};
  p += offset;
  return glm::min(p - glm::floor(p), glm::vec2(0x1.fffffep-1f));
}

// ---- The splat kernel (§6.1) ------------------------------------------------------------------

struct KernelParams {
  float n_tile = 3.2f;   // the radius multiplier of Eq. 6.2
  float r_min = 0.005f;  // Eq. 6.2's clamp of the density radius, m
  float r_max = 0.25f;
  float l_max = 1.f;  // Eq. 6.1's ray length of the widest kernel, m
  float s_n = 0.25f;  // compression along the normal
  float s_max = 5.f;  // Eq. 6.3's clamp of the stretch along the projected light direction

  constexpr bool operator==(const KernelParams&) const = default;
};

// An ellipsoid kernel: axes u (the incident direction projected on the tangent plane), t and n
// (the photon's normal), each a unit vector and a half-length, and the irradiance it adds over its
// ellipse (Eq. 6.6, E = Phi / (pi |u| |t|)).
struct Kernel {
  glm::vec3 center{0.f};
  float pad0 = 0;
  glm::vec3 u{1, 0, 0};
  float u_length = 0;
  glm::vec3 t{0, 1, 0};
  float t_length = 0;
  glm::vec3 n{0, 0, 1};
  float n_length = 0;
  glm::vec3 irradiance{0.f};
  float pad1 = 0;
  glm::vec3 light_direction{0.f};  // towards where the photon came from
  float pad2 = 0;
};
static_assert(sizeof(Kernel) == 96, "std430 layout of the splat instances");

// c_tile of §6.1.1: tan(a_x / 2) tan(a_y / 2) t_x t_y / (r_x r_y) for a tile of `tile` pixels.
inline float tile_constant(float fov_y, uint32_t width, uint32_t height, uint32_t tile) {
  const float ty = std::tan(fov_y / 2), tx = ty * float(width) / float(height);
  return tx * ty * float(tile) * float(tile) / (float(width) * float(height));
}

// The kernel of a photon at `position` with geometric `normal` (facing where it came from),
// travelling along `direction` with `power`, after a ray of `ray_length`; `z_view` its view depth
// and `tile_count` the photons stored in its screen tile (RTG's fix of App. C: s = s_d s_l with
// s_l = clamp(l / l_max, 0.1, 1), and r = 0.1 m for an empty tile).
inline Kernel make_kernel(const glm::vec3& position, const glm::vec3& normal,
                          const glm::vec3& direction, const glm::vec3& power, float ray_length,
                          float z_view, uint32_t tile_count, float c_tile, const KernelParams& k) {
  const float r =
      tile_count > 0 ? std::sqrt(z_view * z_view * c_tile / (kPi * float(tile_count))) : 0.1f;
  const float s_d = std::clamp(r, k.r_min, k.r_max) * k.n_tile;
  const float s_l = std::clamp(ray_length / k.l_max, 0.1f, 1.f);
  const float s = s_d * s_l;
  Kernel out;
  out.center = position;
  out.n = glm::normalize(normal);
  const glm::vec3 wi = -glm::normalize(direction);
  glm::vec3 u = wi - glm::dot(wi, out.n) * out.n;
  if (glm::dot(u, u) < 1e-12f) {  // arriving along the normal: any tangent
    u = std::abs(out.n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    u -= glm::dot(u, out.n) * out.n;
  }
  out.u = glm::normalize(u);
  out.t = glm::cross(out.n, out.u);
  const float cosine = std::max(glm::dot(out.n, wi), 1e-6f);
  const float s_u = std::min(1.f / cosine, k.s_max);  // Eq. 6.3
  out.u_length = s_u * s;
  out.t_length = s;
  out.n_length = k.s_n * s;
  out.irradiance = power / (kPi * out.u_length * out.t_length);  // Eq. 6.6
  out.light_direction = wi;
  return out;
}

// Is `point` inside the kernel's ellipsoid (Eq. 6.5)?
inline bool inside(const Kernel& k, const glm::vec3& point) {
  const glm::vec3 d = point - k.center;
  const float a = glm::dot(d, k.u) / k.u_length, b = glm::dot(d, k.t) / k.t_length,
              c = glm::dot(d, k.n) / k.n_length;
  return a * a + b * b + c * c <= 1.f;
}

// ---- Filtering (§7) ----------------------------------------------------------------------------

// The view samples the filters read: per pixel the world position (w: distance to the camera, 0
// for background) and the shading normal, row-major.
struct Geometry {
  int width = 0, height = 0;
  std::vector<glm::vec4> position, normal;
  bool valid(int x, int y) const {
    return x >= 0 && y >= 0 && x < width && y < height && position[size_t(y) * width + x].w > 0;
  }
  float depth(int x, int y) const { return position[size_t(y) * width + x].w; }
  glm::vec3 normal_at(int x, int y) const { return glm::vec3(normal[size_t(y) * width + x]); }
  // The screen-space depth gradient at a pixel: per axis the one-sided difference of smaller
  // magnitude (a central difference across a depth edge would call the edge a slope and let the
  // a-trous taps leak across it), 0 where no neighbour is valid.
  glm::vec2 depth_gradient(int x, int y) const {
    auto axis = [&](int dx, int dy) {
      const bool fwd = valid(x + dx, y + dy), back = valid(x - dx, y - dy);
      const float f = fwd ? depth(x + dx, y + dy) - depth(x, y) : 0.f;
      const float b = back ? depth(x, y) - depth(x - dx, y - dy) : 0.f;
      if (fwd && back) return std::abs(f) <= std::abs(b) ? f : b;
      return fwd ? f : b;
    };
    return {axis(1, 0), axis(0, 1)};
  }
};

struct FilterParams {
  float alpha_max = 0.95f;  // Eq. 7.4
  float sigma_z = 1.f;      // §7.1 (the thesis's value)
  float sigma_n = 32.f;     // §7.1 (the thesis's value)
  float epsilon = 0.01f;    // w_z's epsilon, a fraction of the pixel's depth (unspecified)
  int iterations = 4;       // a-trous iterations (§7.3)
  bool detail_clip = true;  // §7.3.1
  float gamma = 0.05f;      // §7.3.1: the clip is gamma sigma

  constexpr bool operator==(const FilterParams&) const = default;
};

// §7.1: w_n = max(0, n_p . n_q)^sigma_n; w_z = exp(-|z_p - z_q| / (sigma_z |grad z . (p - q)| +
// epsilon)).
inline float weight_normal(const glm::vec3& np, const glm::vec3& nq, float sigma_n) {
  return std::pow(std::max(0.f, glm::dot(np, nq)), sigma_n);
}
inline float weight_depth(float zp, float zq, float gradient_step, const FilterParams& f) {
  return std::exp(-std::abs(zp - zq) / (f.sigma_z * std::abs(gradient_step) + f.epsilon * zp));
}

// Bilinear upsampling of a `scale` times smaller image (§6.2.1: at the start of the temporal pass).
inline std::vector<glm::vec3> upsample(const std::vector<glm::vec3>& small, int small_width,
                                       int small_height, int width, int height, int scale) {
  std::vector<glm::vec3> out(size_t(width) * height);
  if (scale == 1) {
    out = small;
    return out;
  }
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float sx = (float(x) + 0.5f) / float(scale) - 0.5f;
      const float sy = (float(y) + 0.5f) / float(scale) - 0.5f;
      const int x0 = int(std::floor(sx)), y0 = int(std::floor(sy));
      const float fx = sx - float(x0), fy = sy - float(y0);
      auto at = [&](int ix, int iy) {
        ix = std::clamp(ix, 0, small_width - 1), iy = std::clamp(iy, 0, small_height - 1);
        return small[size_t(iy) * small_width + ix];
      };
      out[size_t(y) * width + x] = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
                                   fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
    }
  return out;
}

// The history of the temporal filter: its output of the last frame, with that frame's view.
struct History {
  bool valid = false;
  Geometry geometry;
  glm::mat4 view_projection{1.f};
  glm::vec3 camera{0.f};
  std::vector<glm::vec3> irradiance, direction;
};

// §7.2, Eq. 7.3-7.4: S = (1 - alpha) E + alpha S_prev(q), alpha = alpha_max w_z w_n, q the
// pixel the point was seen at in the last frame (reprojected with the last frame's camera). w_z
// compares the point's distance from the last camera with the distance stored at q; its gradient
// term takes the sub-pixel offset of the reprojection. Where q is off screen or background, S = E.
inline void temporal(const Geometry& g, const History& h, const FilterParams& f,
                     std::vector<glm::vec3>& irradiance, std::vector<glm::vec3>& direction) {
  if (!h.valid || h.geometry.width != g.width || h.geometry.height != g.height) return;
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) {
      if (!g.valid(x, y)) continue;
      const size_t i = size_t(y) * g.width + x;
      const glm::vec3 p = glm::vec3(g.position[i]);
      const glm::vec4 clip = h.view_projection * glm::vec4(p, 1.f);
      if (!(clip.w > 0)) continue;
      const glm::vec2 ndc = glm::vec2(clip) / clip.w;
      const glm::vec2 pixel = (ndc * 0.5f + 0.5f) * glm::vec2(float(g.width), float(g.height));
      const int qx = int(std::floor(pixel.x)), qy = int(std::floor(pixel.y));
      if (!h.geometry.valid(qx, qy)) continue;
      const size_t j = size_t(qy) * g.width + qx;
      const float expected = glm::distance(h.camera, p);
      const glm::vec2 offset = pixel - (glm::vec2(float(qx), float(qy)) + 0.5f);
      const float step = glm::dot(h.geometry.depth_gradient(qx, qy), offset);
      const float alpha = f.alpha_max * weight_depth(expected, h.geometry.depth(qx, qy), step, f) *
                          weight_normal(g.normal_at(x, y), h.geometry.normal_at(qx, qy), f.sigma_n);
      irradiance[i] = (1 - alpha) * irradiance[i] + alpha * h.irradiance[j];
      direction[i] = (1 - alpha) * direction[i] + alpha * h.direction[j];
    }
}

// §7.3, Eq. 7.5-7.8: `iterations` edge-avoiding a-trous steps (5x5 taps 2^i apart, h = (1/8, 1/4,
// 1/2, 1/4, 1/8) per axis, w = w_z w_n); with detail_clip each step's detail D_i = S_i - S_{i+1}
// is kept clamped to +-gamma sigma_i (sigma_i the weighted standard deviation of S_i over the
// taps, per channel) and the result is S_N + sum_i clamp(D_i) (Eq. 7.8 with the sign the
// telescoping sum S_0 = S_N + sum D_i gives; the thesis prints a minus). The mean light direction
// is filtered with the same weights, without details.
inline void atrous(const Geometry& g, const FilterParams& f, std::vector<glm::vec3>& irradiance,
                   std::vector<glm::vec3>& direction) {
  static constexpr float kH[5] = {0.125f, 0.25f, 0.5f, 0.25f, 0.125f};
  const size_t n = size_t(g.width) * g.height;
  std::vector<glm::vec3> s = irradiance, next(n), dir_next(n), details(n, glm::vec3(0.f));
  for (int it = 0; it < f.iterations; ++it) {
    const int step = 1 << it;
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        const size_t i = size_t(y) * g.width + x;
        if (!g.valid(x, y)) {
          next[i] = s[i], dir_next[i] = direction[i];
          continue;
        }
        const float zp = g.depth(x, y);
        const glm::vec3 np = g.normal_at(x, y);
        const glm::vec2 grad = g.depth_gradient(x, y);
        float wsum = 0;
        glm::vec3 m1(0.f), m2(0.f), d(0.f);
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx) {
            const int qx = x + dx * step, qy = y + dy * step;
            if (!g.valid(qx, qy)) continue;
            const size_t j = size_t(qy) * g.width + qx;
            const float step_depth = glm::dot(grad, glm::vec2(float(dx * step), float(dy * step)));
            const float w = kH[dx + 2] * kH[dy + 2] *
                            weight_depth(zp, g.depth(qx, qy), step_depth, f) *
                            weight_normal(np, g.normal_at(qx, qy), f.sigma_n);
            wsum += w;
            m1 += w * s[j];
            m2 += w * s[j] * s[j];
            d += w * direction[j];
          }
        // The centre tap always counts (w = 1/4 there), so wsum > 0.
        next[i] = m1 / wsum;
        dir_next[i] = d / wsum;
        if (f.detail_clip) {
          const glm::vec3 sigma =
              glm::sqrt(glm::max(m2 / wsum - next[i] * next[i], glm::vec3(0.f)));
          details[i] += glm::clamp(s[i] - next[i], -f.gamma * sigma, f.gamma * sigma);
        }
      }
    std::swap(s, next);
    std::swap(direction, dir_next);
  }
  for (size_t i = 0; i < n; ++i) irradiance[i] = s[i] + details[i];
}

// The geometric normal of a pixel from its neighbours' positions (the G-buffer holds the shading
// normal only): the cross product of the horizontal and vertical differences, each taken on the
// side whose depth is closer, facing the shading normal.
inline glm::vec3 geometric_normal(const Geometry& g, int x, int y) {
  const size_t i = size_t(y) * g.width + x;
  const glm::vec3 p = glm::vec3(g.position[i]);
  auto side = [&](int dx, int dy) -> glm::vec3 {
    const bool fwd = g.valid(x + dx, y + dy), back = g.valid(x - dx, y - dy);
    auto at = [&](int ax, int ay) { return glm::vec3(g.position[size_t(ay) * g.width + ax]); };
    if (fwd && back) {
      const float zf = std::abs(g.depth(x + dx, y + dy) - g.depth(x, y));
      const float zb = std::abs(g.depth(x - dx, y - dy) - g.depth(x, y));
      return zf <= zb ? at(x + dx, y + dy) - p : p - at(x - dx, y - dy);
    }
    if (fwd) return at(x + dx, y + dy) - p;
    if (back) return p - at(x - dx, y - dy);
    return glm::vec3(0.f);
  };
  glm::vec3 n = glm::cross(side(1, 0), side(0, 1));
  const glm::vec3 ns = g.normal_at(x, y);
  if (glm::dot(n, n) < 1e-20f) return ns;
  n = glm::normalize(n);
  return glm::dot(n, ns) < 0 ? -n : n;
}

struct ShadeParams {
  bool direction_term = false;  // §7.4, Eq. 7.10
  float sl_max = 4.f;           // Eq. 7.10's clamp of 1 / (w . n_geometric)
  float epsilon = 0.05f;        // Eq. 7.10's epsilon

  constexpr bool operator==(const ShadeParams&) const = default;
};

// §7.4: L = E albedo / pi (Eq. 7.9), with the direction term (Eq. 7.10 as the prose reads it:
// times the cosine with the shading normal, divided by the cosine with the geometric one, at most
// sl_max) when asked for.
inline glm::vec3 shade(const glm::vec3& irradiance, const glm::vec3& albedo,
                       const glm::vec3& direction, const glm::vec3& shading_normal,
                       const glm::vec3& geometric, const ShadeParams& s) {
  glm::vec3 l = irradiance * albedo / kPi;
  if (!s.direction_term) return l;
  const float len = glm::length(direction);
  if (!(len > 0)) return l;
  const glm::vec3 w = direction / len;
  const float term = std::max(0.f, glm::dot(w, shading_normal)) *
                     std::min(1.f / (std::max(0.f, glm::dot(w, geometric)) + s.epsilon), s.sl_max);
  return l * term;
}

}  // namespace rsm
