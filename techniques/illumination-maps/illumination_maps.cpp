#include "illumination_maps.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <limits>
#include <numeric>

namespace im {

tk::SelectiveEmissionSettings selective_settings(const ImParams& p) {
  pb::trace::TraceSettings trace;
  trace.max_bounces = p.max_bounces;
  trace.store = pb::trace::kAllPhotons;
  return p.settings(trace);
}

std::string check(const pb::Params& params) {
  const ImParams p = kParams.read(params);
  const uint32_t size = p.hemi_size;
  if ((size & (size - 1)) != 0)
    return fmt::format(
        "hemi_size: {} is not a power of two (the MIP reduction halves the hemi-plane to one "
        "pixel, Ch. 11)",
        size);
  if (p.emission == Emission::selective) return tk::check_selective_emission_params(p);
  return "";
}

double hemi_plane_coverage(double half_width) {
  const double s = half_width / std::sqrt(1.0 + half_width * half_width);
  return 4.0 / M_PI * s * std::atan(s);
}

double hemi_plane_weight_sum(uint32_t size, float half_width) {
  double sum = 0;
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) sum += im_hemi_weight(x, y, size, half_width);
  return sum;
}

glm::vec3 hemi_plane_irradiance(glm::vec3 top, float scale_8bit, uint32_t sum_precision,
                                float weight_sum) {
  const float unscale = sum_precision == IM_SUM_8BIT ? 1.0f / scale_8bit : 1.0f;
  return float(M_PI) * top * unscale / weight_sum;
}

float hemi_plane_scale_8bit(float largest_radiance, uint32_t size, float half_width) {
  const float peak = im_hemi_weight(size / 2, size / 2, size, half_width) * float(size * size);
  return largest_radiance > 0 ? 1.0f / (largest_radiance * peak) : 1.0f;
}

namespace {

// Barycentric coordinates of `p` in the 2D triangle (a, b, c); nullopt for a degenerate one.
bool barycentric(glm::vec2 p, glm::vec2 a, glm::vec2 b, glm::vec2 c, glm::vec3& w) {
  const glm::vec2 e0 = b - a, e1 = c - a, d = p - a;
  const float den = e0.x * e1.y - e1.x * e0.y;
  if (std::abs(den) < 1e-20f) return false;
  const float v = (d.x * e1.y - e1.x * d.y) / den;
  const float u = (e0.x * d.y - d.x * e0.y) / den;
  w = glm::vec3(1.f - v - u, v, u);
  return true;
}

// The closest point of segment (a, b) to p.
glm::vec2 closest_on_segment(glm::vec2 p, glm::vec2 a, glm::vec2 b) {
  const glm::vec2 ab = b - a;
  const float len2 = glm::dot(ab, ab);
  const float t = len2 > 0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.f, 1.f) : 0.f;
  return a + t * ab;
}

float radical_inverse2(uint32_t i) {
  i = (i << 16u) | (i >> 16u);
  i = ((i & 0x55555555u) << 1u) | ((i & 0xAAAAAAAAu) >> 1u);
  i = ((i & 0x33333333u) << 2u) | ((i & 0xCCCCCCCCu) >> 2u);
  i = ((i & 0x0F0F0F0Fu) << 4u) | ((i & 0xF0F0F0F0u) >> 4u);
  i = ((i & 0x00FF00FFu) << 8u) | ((i & 0xFF00FF00u) >> 8u);
  return float(i) * 2.3283064365386963e-10f;
}

float hash_unit(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return float(x >> 8) * (1.0f / 16777216.0f);
}

float channel_sum(glm::dvec3 v) { return float(std::abs(v.x) + std::abs(v.y) + std::abs(v.z)); }

}  // namespace

glm::vec3 cosine_direction(glm::vec3 n, float u1, float u2) {
  // An orthonormal basis about n (Duff et al. 2017's branchless form).
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z), b = n.x * n.y * a;
  const glm::vec3 t(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
  const glm::vec3 s(b, sign + n.y * n.y * a, -n.y);
  const float r = std::sqrt(u1), phi = 2.0f * float(M_PI) * u2;
  return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * s +
                        std::sqrt(std::max(0.0f, 1.0f - u1)) * n);
}

glm::mat4 hemi_plane_view_projection(glm::vec3 position, glm::vec3 normal, float half_width,
                                     float near, float far) {
  const glm::vec3 up = std::abs(normal.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::mat4 view = glm::lookAtRH(position, position + normal, up);
  glm::mat4 projection = glm::perspectiveRH_ZO(2.0f * std::atan(half_width), 1.0f, near, far);
  projection[1][1] *= -1.0f;  // Vulkan's clip space: y down
  return projection * view;
}

void IlluminationMaps::build(const pb::SceneTriangles& triangles, std::span<const glm::vec3> albedo,
                             float crease_angle_degrees, uint32_t aim_texels, bool keep_unmoved) {
  std::vector<ChartMap> old_charts = std::move(charts_);
  const std::vector<uint32_t> old_chart_of = chart_of_;
  const std::vector<TexelSite> old_sites = sites_;
  const std::vector<glm::vec4> old_aim = aim_;
  const std::vector<double> old_change = input_change_;
  const std::vector<bool> old_gathered = gathered_;
  std::vector<glm::vec3> positions(triangles.vertex_count());
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (uint32_t v = 0; v < triangles.vertex_count(); ++v) {
    positions[v] = glm::vec3(triangles.host_vertices[v].position);
    lo = glm::min(lo, positions[v]);
    hi = glm::max(hi, positions[v]);
  }
  epsilon_ = triangles.vertex_count() > 0 ? std::max(1e-6f, 1e-4f * glm::length(hi - lo)) : 1e-4f;
  std::vector<glm::uvec3> indices(triangles.triangle_count());
  for (uint32_t t = 0; t < triangles.triangle_count(); ++t)
    indices[t] = glm::uvec3(triangles.host_triangles[t].vertices_object);
  tk::Charts charts = tk::segment_charts(positions, indices, crease_angle_degrees);
  chart_of_ = std::move(charts.chart_of);
  charts_.assign(charts.charts.size(), {});
  sites_.clear();
  total_area_ = 0;
  // One texel size for the scene: aim_texels along the largest chart's longer side.
  float largest = 0;
  for (const tk::Chart& c : charts.charts) largest = std::max({largest, c.extent.x, c.extent.y});
  const float texel = largest > 0 ? largest / float(aim_texels) : 1.0f;
  for (size_t ci = 0; ci < charts.charts.size(); ++ci) {
    const tk::Chart& c = charts.charts[ci];
    ChartMap& m = charts_[ci];
    m.area = c.area;
    total_area_ += c.area;
    ImChart& g = m.grid;
    g.axis = c.axis;
    // The 1e-3 keeps a side of exactly n texels at n despite rounding.
    g.width = std::max(1u, uint32_t(std::ceil(c.extent.x / texel - 1e-3f)));
    g.height = std::max(1u, uint32_t(std::ceil(c.extent.y / texel - 1e-3f)));
    g.first_texel = uint32_t(sites_.size());
    g.lower_u = c.lower.x;
    g.lower_v = c.lower.y;
    g.texels_per_m_u = c.extent.x > 0 ? float(g.width) / c.extent.x : 0.f;
    g.texels_per_m_v = c.extent.y > 0 ? float(g.height) / c.extent.y : 0.f;
    for (uint32_t j = 0; j < g.height; ++j)
      for (uint32_t i = 0; i < g.width; ++i) {
        const glm::vec2 centre((float(i) + 0.5f) * c.extent.x / float(g.width),
                               (float(j) + 0.5f) * c.extent.y / float(g.height));
        // The chart's triangle under the centre in the uv plane, else the closest point of its
        // triangles (a texel beyond the chart's outline, whose estimate the bilinear lookup
        // still reads at the outline).
        float best = std::numeric_limits<float>::max();
        TexelSite site;
        site.chart = uint32_t(ci);
        for (uint32_t t : c.triangles) {
          const glm::uvec3 tri = indices[t];
          const glm::vec3 p0 = positions[tri.x], p1 = positions[tri.y], p2 = positions[tri.z];
          const glm::vec2 a = c.uv(p0), b = c.uv(p1), d = c.uv(p2);
          glm::vec3 w;
          if (!barycentric(centre, a, b, d, w)) continue;
          glm::vec2 q = centre;
          if (w.x < 0 || w.y < 0 || w.z < 0) {
            const glm::vec2 candidates[3] = {closest_on_segment(centre, a, b),
                                             closest_on_segment(centre, b, d),
                                             closest_on_segment(centre, d, a)};
            q = candidates[0];
            for (const glm::vec2& k : candidates)
              if (glm::distance(k, centre) < glm::distance(q, centre)) q = k;
            barycentric(q, a, b, d, w);
          }
          const float distance = glm::distance(q, centre);
          if (distance >= best) continue;
          best = distance;
          site.position = w.x * p0 + w.y * p1 + w.z * p2;
          site.normal = glm::vec3(triangles.host_triangles[t].normal_area);
          const uint32_t material = triangles.material(t);
          site.albedo = material < albedo.size() ? albedo[material] : glm::vec3(0.f);
          if (distance == 0) break;
        }
        sites_.push_back(site);
      }
  }
  aim_.assign(sites_.size(), glm::vec4(0.f));
  input_change_.assign(sites_.size(), 0.0);
  gathered_.assign(sites_.size(), false);
  texel_before_.assign(sites_.size(), kNoTexel);
  fresh_charts_.clear();
  const bool same_partition =
      keep_unmoved && chart_of_ == old_chart_of && charts_.size() == old_charts.size();
  for (uint32_t c = 0; c < charts_.size(); ++c) {
    ChartMap& m = charts_[c];
    bool unmoved = same_partition;
    if (unmoved) {
      const ImChart a = m.grid, b = old_charts[c].grid;
      unmoved = a.axis == b.axis && a.width == b.width && a.height == b.height &&
                a.lower_u == b.lower_u && a.lower_v == b.lower_v &&
                a.texels_per_m_u == b.texels_per_m_u && a.texels_per_m_v == b.texels_per_m_v;
      for (uint32_t t = 0; unmoved && t < a.width * a.height; ++t)
        unmoved = sites_[a.first_texel + t].position == old_sites[b.first_texel + t].position;
    }
    if (!unmoved) {
      fresh_charts_.push_back(c);
      continue;
    }
    const ImChart grid = m.grid;
    const uint32_t before = old_charts[c].grid.first_texel;
    m = std::move(old_charts[c]);
    m.grid = grid;
    for (uint32_t t = 0; t < grid.width * grid.height; ++t) {
      const uint32_t now = grid.first_texel + t;
      texel_before_[now] = before + t;
      sites_[now].normal = old_sites[before + t].normal;  // the lit side found before
      aim_[now] = old_aim[before + t];
      input_change_[now] = old_change[before + t];
      gathered_[now] = old_gathered[before + t];
    }
  }
}

uint32_t IlluminationMaps::charts_without_aim() const {
  return uint32_t(std::count_if(charts_.begin(), charts_.end(),
                                [](const ChartMap& m) { return !m.aim_valid; }));
}

uint32_t IlluminationMaps::texels_never_gathered() const {
  return uint32_t(std::count(gathered_.begin(), gathered_.end(), false));
}

void IlluminationMaps::store_photons(std::span<const pb::trace::PhotonRecord> photons) {
  for (ChartMap& m : charts_) {
    m.positions.clear();
    m.powers.clear();
    m.normals.clear();
    m.flux = glm::dvec3(0.0);
  }
  for (const pb::trace::PhotonRecord& p : photons) {
    if (p.triangle >= chart_of_.size()) continue;
    ChartMap& m = charts_[chart_of_[p.triangle]];
    m.positions.push_back(p.position);
    m.powers.push_back(p.power);
    m.normals.push_back(p.normal);
    m.flux += glm::dvec3(p.power);
  }
  for (ChartMap& m : charts_) m.tree = tk::KdTree(m.positions);
}

void IlluminationMaps::store_chart_photons(std::span<const pb::trace::PhotonRecord> photons,
                                           std::span<const uint32_t> charts,
                                           const tk::SurfaceEnergyLedger& ledger) {
  std::vector<bool> taken(charts_.size(), false);
  for (uint32_t c : charts) {
    if (c >= charts_.size()) continue;
    taken[c] = true;
    ChartMap& m = charts_[c];
    m.positions.clear();
    m.powers.clear();
    m.normals.clear();
    m.flux = ledger.watts(c);
  }
  for (const pb::trace::PhotonRecord& p : photons) {
    if (p.triangle >= chart_of_.size() || !taken[chart_of_[p.triangle]]) continue;
    ChartMap& m = charts_[chart_of_[p.triangle]];
    m.positions.push_back(p.position);
    m.powers.push_back(p.power);
    m.normals.push_back(p.normal);
  }
  for (uint32_t c : charts)
    if (c < charts_.size()) charts_[c].tree = tk::KdTree(charts_[c].positions);
}

glm::vec3 IlluminationMaps::estimate_aim(uint32_t texel, uint32_t k) const {
  const TexelSite& site = sites_[texel];
  const ChartMap& m = charts_[site.chart];
  thread_local std::vector<tk::KdTree::Neighbour> found;
  m.tree.nearest(site.position, k, std::numeric_limits<float>::infinity(), found);
  glm::dvec3 power(0.0);
  for (const tk::KdTree::Neighbour& n : found) power += glm::dvec3(m.powers[n.index]);
  double area = 0;
  if (found.size() < k || found.back().distance2 <= 0.f) {
    // Fewer photons on the chart than N: the chart's mean irradiance (all of its flux over its
    // area) instead of a disc the photons do not fill.
    power = m.flux;
    area = m.area;
  } else {
    area = M_PI * double(found.back().distance2);
  }
  if (area <= 0) return glm::vec3(0.f);
  return site.albedo * float(1.0 / M_PI) * glm::vec3(power / area);
}

std::vector<glm::vec3> IlluminationMaps::texel_mean_aim(uint32_t chart) const {
  const ChartMap& m = charts_[chart];
  const ImChart& g = m.grid;
  std::vector<glm::dvec3> power(size_t(g.width) * g.height, glm::dvec3(0.0));
  for (size_t i = 0; i < m.positions.size(); ++i) {
    const glm::vec3 p = m.positions[i];
    const float u = (p[(g.axis + 1) % 3] - g.lower_u) * g.texels_per_m_u;
    const float v = (p[(g.axis + 2) % 3] - g.lower_v) * g.texels_per_m_v;
    const uint32_t x = std::min(g.width - 1, uint32_t(std::max(0.f, u)));
    const uint32_t y = std::min(g.height - 1, uint32_t(std::max(0.f, v)));
    power[size_t(y) * g.width + x] += glm::dvec3(m.powers[i]);
  }
  const double texel_area = m.area / double(power.size());
  std::vector<glm::vec3> out(power.size(), glm::vec3(0.f));
  if (texel_area <= 0) return out;
  for (size_t t = 0; t < power.size(); ++t)
    out[t] =
        sites_[g.first_texel + t].albedo * float(1.0 / M_PI) * glm::vec3(power[t] / texel_area);
  return out;
}

uint32_t IlluminationMaps::update_aims(uint32_t max_charts, float threshold, uint32_t k,
                                       AimEstimate estimate) {
  glm::dvec3 total(0.0);
  for (const ChartMap& m : charts_) total += m.flux;
  const double mean = total_area_ > 0 ? channel_sum(total) / total_area_ : 0.0;
  struct Candidate {
    double change;  // |delta f| / A (W / m^2), infinite for a chart never computed
    uint32_t chart;
  };
  std::vector<Candidate> candidates;
  for (uint32_t c = 0; c < charts_.size(); ++c) {
    const ChartMap& m = charts_[c];
    const double change = m.aim_valid
                              ? (m.area > 0 ? channel_sum(m.flux - m.flux_at_aim) / m.area : 0.0)
                              : std::numeric_limits<double>::infinity();
    if (!m.aim_valid || change > double(threshold) * mean) candidates.push_back({change, c});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.change > b.change; });
  if (candidates.size() > max_charts) candidates.resize(max_charts);
  double aim_change = 0;  // the AIMs' change, summed over texels (radiance times texel area)
  std::vector<tk::KdTree::Neighbour> found;
  for (const Candidate& candidate : candidates) {
    ChartMap& m = charts_[candidate.chart];
    const uint32_t texels = m.grid.width * m.grid.height;
    const double texel_area = m.area / texels;
    const std::vector<glm::vec3> means =
        estimate == AimEstimate::texel ? texel_mean_aim(candidate.chart) : std::vector<glm::vec3>();
    for (uint32_t t = m.grid.first_texel; t < m.grid.first_texel + texels; ++t) {
      // The side the light arrives on is the side the gather looks from (a mesh's winding may face
      // either way): the texel's normal is turned towards its nearest photons' when they disagree.
      TexelSite& site = sites_[t];
      m.tree.nearest(site.position, k, std::numeric_limits<float>::infinity(), found);
      glm::vec3 arriving(0.f);
      for (const tk::KdTree::Neighbour& n : found) arriving += m.normals[n.index];
      if (glm::dot(arriving, site.normal) < 0.f) site.normal = -site.normal;
      const glm::vec3 radiance =
          estimate == AimEstimate::texel ? means[t - m.grid.first_texel] : estimate_aim(t, k);
      aim_change += texel_area * channel_sum(glm::dvec3(radiance - glm::vec3(aim_[t])));
      aim_[t] = glm::vec4(radiance, 0.f);
    }
    m.flux_at_aim = m.flux;
    m.aim_valid = true;
  }
  // Every texel may see every chart (which it does is what the gather finds out), so each texel's
  // delta i grows by the whole change: texels are then gathered oldest first while the AIMs move.
  if (aim_change > 0)
    for (double& change : input_change_) change += aim_change;
  return uint32_t(candidates.size());
}

std::vector<uint32_t> IlluminationMaps::take_gather_texels(uint32_t max_texels) {
  std::vector<uint32_t> order;
  for (uint32_t t = 0; t < sites_.size(); ++t)
    if (!gathered_[t] || input_change_[t] > 0) order.push_back(t);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    if (gathered_[a] != gathered_[b]) return !gathered_[a];
    return input_change_[a] > input_change_[b];
  });
  if (order.size() > max_texels) order.resize(max_texels);
  for (uint32_t t : order) {
    gathered_[t] = true;
    input_change_[t] = 0;
  }
  return order;
}

glm::vec3 IlluminationMaps::aim_radiance(uint32_t chart, glm::vec3 p,
                                         glm::vec3 towards_viewer) const {
  const ImBilinear b = im_bilinear(charts_[chart].grid, p);
  glm::vec3 sum(0.f);
  for (int i = 0; i < 4; ++i)
    if (glm::dot(sites_[b.texel[i]].normal, towards_viewer) > 0.f)
      sum += b.weight[i] * glm::vec3(aim_[b.texel[i]]);
  return sum;
}

glm::vec3 IlluminationMaps::gather_rays(uint32_t texel, const tk::TriangleRayCaster& caster,
                                        uint32_t rays) const {
  const TexelSite& site = sites_[texel];
  const glm::vec3 origin = site.position + epsilon_ * site.normal;
  // Hammersley points, moved by one random offset per texel (Cranley-Patterson rotation).
  const float shift_u = hash_unit(2 * texel + 1), shift_v = hash_unit(2 * texel + 2);
  glm::dvec3 sum(0.0);
  for (uint32_t i = 0; i < rays; ++i) {
    const float u1 = std::fmod((float(i) + 0.5f) / float(rays) + shift_u, 1.0f);
    const float u2 = std::fmod(radical_inverse2(i) + shift_v, 1.0f);
    const glm::vec3 d = cosine_direction(site.normal, u1, u2);
    const auto hit = caster.closest(origin, d, 0.f, std::numeric_limits<float>::infinity());
    if (!hit || hit->triangle >= chart_of_.size()) continue;
    sum += glm::dvec3(aim_radiance(chart_of_[hit->triangle], origin + hit->distance * d, -d));
  }
  return glm::vec3(M_PI * sum / double(std::max(1u, rays)));
}

}  // namespace im
