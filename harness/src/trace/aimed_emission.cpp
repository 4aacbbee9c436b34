#include "trace/aimed_emission.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "trace/lights.h"

namespace pb::trace {
namespace {

struct BoundingSphere {
  glm::vec3 centre{0.f};
  float radius = 0;
};

// A specular object's bounding sphere and those of its triangles in runs of kAimCluster (meshes
// are tessellated in order, so a run is a compact patch): two levels, so a texel tests the
// object's sphere first and the runs only when that one is met.
struct SpecularTarget {
  BoundingSphere whole;
  std::vector<BoundingSphere> runs;
};
constexpr uint32_t kAimCluster = 16;

BoundingSphere sphere_around(const glm::vec3* points, size_t n) {
  Aabb box;
  for (size_t k = 0; k < n; ++k) box.extend(points[k]);
  BoundingSphere s;
  s.centre = 0.5f * (box.lo + box.hi);
  for (size_t k = 0; k < n; ++k) s.radius = std::max(s.radius, glm::length(points[k] - s.centre));
  s.radius = s.radius * 1.001f + 1e-5f;  // float rounding of the points themselves
  return s;
}

std::vector<SpecularTarget> specular_targets(const EmbreeScene& world) {
  const scene::Scene& scene = world.scene();
  std::vector<SpecularTarget> targets;
  for (uint32_t o = 0; o < world.object_count(); ++o) {
    auto type = scene.materials[scene.objects[o].material].type;
    if (type == scene::MaterialType::diffuse || type == scene::MaterialType::emissive) continue;
    uint32_t triangles = uint32_t(world.mesh(o).triangles.size());
    if (triangles == 0) continue;
    SpecularTarget t;
    std::vector<glm::vec3> all, run;
    for (uint32_t first = 0; first < triangles; first += kAimCluster) {
      run.clear();
      for (uint32_t k = first; k < std::min(triangles, first + kAimCluster); ++k) {
        Triangle tri = world.triangle(o, k);
        run.insert(run.end(), tri.p, tri.p + 3);
      }
      t.runs.push_back(sphere_around(run.data(), run.size()));
      all.insert(all.end(), run.begin(), run.end());
    }
    t.whole = sphere_around(all.data(), all.size());
    targets.push_back(std::move(t));
  }
  return targets;
}

// The rays of one texel of a delta-origin light: from one origin within a cone (point, spot), or
// along one direction from origins within a disc (directional).
struct RayBundle {
  bool parallel = false;
  glm::vec3 origin{0.f}, axis{0.f};
  float spread = 0;  // the cone's half-angle (radians) or the disc's radius (m)
  bool may_meet(const BoundingSphere& s) const {
    glm::vec3 to = s.centre - origin;
    float along = glm::dot(to, axis);
    if (parallel) {  // the sphere in front of the disc, its centre near the bundle's axis
      float off_axis = glm::length(to - along * axis);
      return along >= -s.radius && off_axis <= s.radius + spread;
    }
    float d = glm::length(to);
    if (d <= s.radius) return true;
    float angle = std::acos(std::clamp(along / d, -1.f, 1.f));
    return angle <= spread + std::asin(s.radius / d);
  }
};

// Texel (i, j) of emitter `e`'s emission domain (u in [i, i+1) / n, v in [j, j+1) / n) as a ray
// bundle. A cone's half-angle is the largest angle from the centre direction to 16 points on the
// texel's border plus half the largest angle between neighbouring border points: every border
// point lies within that half-gap of a sampled one, and on a sphere the farthest point of a small
// region from an inner point lies on its border.
RayBundle texel_bundle(const LightSet& lights, uint32_t e, int i, int j, int n) {
  auto at = [&](float u, float v) { return lights.emit(e, {u / n, v / n}, {0.5f, 0.5f}); };
  EmissionRay centre = at(i + 0.5f, j + 0.5f);
  RayBundle b;
  b.origin = centre.origin;
  b.axis = glm::normalize(centre.direction);
  constexpr int kPerEdge = 4;
  std::array<glm::vec2, 4 * kPerEdge> border;
  for (int k = 0; k < kPerEdge; ++k) {
    float t = float(k) / kPerEdge;
    border[k] = {i + t, float(j)};
    border[kPerEdge + k] = {i + 1.f, j + t};
    border[2 * kPerEdge + k] = {i + 1.f - t, j + 1.f};
    border[3 * kPerEdge + k] = {float(i), j + 1.f - t};
  }
  if (lights.emitter(e).type == EmitterType::directional) {
    b.parallel = true;  // the origins span a parallelogram: its farthest point is a corner
    for (int k = 0; k < 4; ++k) {
      glm::vec2 c = border[k * kPerEdge];
      b.spread = std::max(b.spread, glm::length(at(c.x, c.y).origin - b.origin));
    }
    b.spread = b.spread * 1.001f + 1e-5f;
    return b;
  }
  auto angle = [](glm::vec3 a, glm::vec3 c) {
    return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(c)), -1.f, 1.f));
  };
  std::array<glm::vec3, border.size()> dirs;
  for (size_t k = 0; k < border.size(); ++k) dirs[k] = at(border[k].x, border[k].y).direction;
  float far = 0, gap = 0;
  for (size_t k = 0; k < dirs.size(); ++k) {
    far = std::max(far, angle(b.axis, dirs[k]));
    gap = std::max(gap, angle(dirs[k], dirs[(k + 1) % dirs.size()]));
  }
  b.spread = (far + 0.5f * gap) * 1.01f + 1e-4f;
  return b;
}

// Emitter `e`'s aimed density (1 where a texel's rays may meet a specular target, else 0), or
// nothing for area emitters and for lights no specular target can be reached from.
std::optional<EmissionDensity> aimed_density(const LightSet& lights, uint32_t e,
                                             const std::vector<SpecularTarget>& targets) {
  EmitterType type = lights.emitter(e).type;
  if (type != EmitterType::point && type != EmitterType::spot && type != EmitterType::directional)
    return std::nullopt;
  const int n = kAimResolution;
  EmissionDensity d;
  d.width = d.height = n;
  d.texels.assign(size_t(n) * n, 0.f);
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& rows) {
    for (int j = rows.begin(); j != rows.end(); ++j)
      for (int i = 0; i < n; ++i) {
        RayBundle b = texel_bundle(lights, e, i, j, n);
        bool meets = false;
        for (const SpecularTarget& t : targets) {
          if (!b.may_meet(t.whole)) continue;
          for (const BoundingSphere& s : t.runs)
            if (b.may_meet(s)) {
              meets = true;
              break;
            }
          if (meets) break;
        }
        d.texels[size_t(j) * n + i] = meets ? 1.f : 0.f;
      }
  });
  if (std::all_of(d.texels.begin(), d.texels.end(), [](float v) { return v == 0.f; }))
    return std::nullopt;
  return d;
}

}  // namespace

std::vector<std::optional<EmissionDensity>> aimed_emission_densities(const EmbreeScene& world) {
  LightSet lights(world);
  std::vector<SpecularTarget> targets = specular_targets(world);
  std::vector<std::optional<EmissionDensity>> out(lights.size());
  if (targets.empty()) return out;
  for (uint32_t e = 0; e < lights.size(); ++e) out[e] = aimed_density(lights, e, targets);
  return out;
}

}  // namespace pb::trace
