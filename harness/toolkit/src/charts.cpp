// segment_charts (photonbench/toolkit/charts.h).
#include "photonbench/toolkit/charts.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "photonbench/error.h"

namespace pb::toolkit {

namespace {

// Vertices within `tolerance` of each other as one: a grid of cells of the tolerance's size, each
// vertex compared with the representatives in its cell and the 26 around it.
std::vector<uint32_t> weld(std::span<const glm::vec3> positions) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  for (const glm::vec3& p : positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
  const double tolerance = positions.empty() ? 0.0 : 1e-5 * double(glm::length(hi - lo));
  const double cell = std::max(tolerance, 1e-30);
  auto key = [](int64_t x, int64_t y, int64_t z) {
    return uint64_t(x) * 0x9E3779B97F4A7C15ull ^ uint64_t(y) * 0xC2B2AE3D27D4EB4Full ^
           uint64_t(z) * 0x165667B19E3779F9ull;
  };
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells;  // key -> representative vertices
  std::vector<uint32_t> welded(positions.size());
  for (uint32_t v = 0; v < positions.size(); ++v) {
    const glm::vec3 p = positions[v];
    const int64_t cx = int64_t(std::floor(p.x / cell)), cy = int64_t(std::floor(p.y / cell)),
                  cz = int64_t(std::floor(p.z / cell));
    welded[v] = v;
    bool found = false;
    for (int64_t dx = -1; dx <= 1 && !found; ++dx)
      for (int64_t dy = -1; dy <= 1 && !found; ++dy)
        for (int64_t dz = -1; dz <= 1 && !found; ++dz) {
          const auto it = cells.find(key(cx + dx, cy + dy, cz + dz));
          if (it == cells.end()) continue;
          for (uint32_t r : it->second)
            if (double(glm::length(positions[r] - p)) <= tolerance) {
              welded[v] = r;
              found = true;
              break;
            }
        }
    if (!found) cells[key(cx, cy, cz)].push_back(v);
  }
  return welded;
}

uint32_t find(std::vector<uint32_t>& parent, uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];  // path halving
  return i;
}

}  // namespace

glm::vec2 Chart::uv(glm::vec3 p) const {
  return glm::vec2(p[(axis + 1) % 3], p[(axis + 2) % 3]) - lower;
}

Charts segment_charts(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                      float crease_angle_degrees) {
  if (!(crease_angle_degrees >= 0.0f && crease_angle_degrees <= 180.0f))
    throw Error(
        fmt::format("crease_angle: {} degrees, must lie in [0, 180]", crease_angle_degrees));
  const uint32_t n = uint32_t(triangles.size());
  for (uint32_t t = 0; t < n; ++t)
    for (int c = 0; c < 3; ++c)
      if (triangles[t][c] >= positions.size())
        throw Error(fmt::format("charts: triangle {} uses vertex {} of {}", t, triangles[t][c],
                                positions.size()));
  const std::vector<uint32_t> welded = weld(positions);

  // Face normals (area-weighted, unnormalised) and unit normals; a degenerate face has none.
  std::vector<glm::vec3> weighted(n), unit(n);
  std::vector<bool> has_normal(n);
  for (uint32_t t = 0; t < n; ++t) {
    const glm::uvec3 tri = triangles[t];
    weighted[t] =
        glm::cross(positions[tri[1]] - positions[tri[0]], positions[tri[2]] - positions[tri[0]]);
    const float length = glm::length(weighted[t]);
    has_normal[t] = length > 0.0f && std::isfinite(length);
    unit[t] = has_normal[t] ? weighted[t] / length : glm::vec3(0.0f);
  }

  // Each edge (two welded vertices, lower first) with the triangles that have it.
  struct EdgeUse {
    uint32_t a, b, triangle;
  };
  std::vector<EdgeUse> edges;
  edges.reserve(size_t(n) * 3);
  for (uint32_t t = 0; t < n; ++t)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = welded[triangles[t][c]], b = welded[triangles[t][(c + 1) % 3]];
      if (a != b) edges.push_back({std::min(a, b), std::max(a, b), t});
    }
  std::sort(edges.begin(), edges.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return std::tie(x.a, x.b, x.triangle) < std::tie(y.a, y.b, y.triangle);
  });

  // Connected edges: normals less than the crease angle apart.
  const float cos_crease = std::cos(glm::radians(crease_angle_degrees));
  std::vector<uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  for (size_t first = 0; first < edges.size();) {
    size_t end = first + 1;
    while (end < edges.size() && edges[end].a == edges[first].a && edges[end].b == edges[first].b)
      ++end;
    for (size_t i = first; i < end; ++i)
      for (size_t j = i + 1; j < end; ++j) {
        const uint32_t s = edges[i].triangle, t = edges[j].triangle;
        if (!has_normal[s] || !has_normal[t] || !(glm::dot(unit[s], unit[t]) > cos_crease))
          continue;
        const uint32_t rs = find(parent, s), rt = find(parent, t);
        if (rs != rt) parent[std::max(rs, rt)] = std::min(rs, rt);  // the lowest triangle roots
      }
    first = end;
  }

  Charts out;
  out.chart_of.resize(n);
  std::vector<uint32_t> chart_of_root(n, UINT32_MAX);
  for (uint32_t t = 0; t < n; ++t) {
    const uint32_t root = find(parent, t);
    if (chart_of_root[root] == UINT32_MAX) {
      chart_of_root[root] = uint32_t(out.charts.size());
      out.charts.emplace_back();
    }
    out.chart_of[t] = chart_of_root[root];
    out.charts[out.chart_of[t]].triangles.push_back(t);
  }

  // Each chart's dominant axis and its uv rectangle.
  for (Chart& chart : out.charts) {
    glm::dvec3 normal(0.0);
    for (uint32_t t : chart.triangles) {
      normal += glm::dvec3(weighted[t]);
      chart.area += 0.5 * double(glm::length(weighted[t]));
    }
    const glm::dvec3 a = glm::abs(normal);
    chart.axis = a.x >= a.y && a.x >= a.z ? 0 : a.y >= a.z ? 1 : 2;
    glm::vec2 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
    for (uint32_t t : chart.triangles)
      for (int c = 0; c < 3; ++c) {
        const glm::vec3 p = positions[triangles[t][c]];
        const glm::vec2 q(p[(chart.axis + 1) % 3], p[(chart.axis + 2) % 3]);
        lo = glm::min(lo, q), hi = glm::max(hi, q);
      }
    chart.lower = lo;
    chart.extent = hi - lo;
  }
  return out;
}

}  // namespace pb::toolkit
