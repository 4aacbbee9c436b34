// collection-points' CPU side (collection_points.h).
#include "collection_points.h"

#include <algorithm>
#include <cmath>

namespace cp {

void make_points(std::span<const pb::trace::CameraPathRecord> paths, float cap, PointSet& out,
                 bool per_pixel) {
  out.points.clear();
  out.boxes.clear();
  out.point_of_pixel.assign(paths.size(), CP_NONE);
  if (per_pixel) {
    CpPoint none{};
    none.material = CP_NONE;
    out.points.assign(paths.size(), none);
    out.boxes.assign(paths.size(), pb::toolkit::empty_box());
  }
  out.count = out.behind_specular = out.capped = 0;
  out.radius_sum = 0;
  for (const pb::trace::CameraPathRecord& path : paths) {
    if (!pb::trace::ends_diffuse(path) || path.material == ~0u) continue;
    CpPoint c{};
    c.position = path.position;
    c.normal = path.normal;
    c.material = path.material;
    c.throughput = path.throughput;
    c.pixel = path.pixel;
    c.specular = pb::trace::specular_vertices(path);
    c.radius = footprint_radius(path, cap);
    if (!(c.radius > 0.0f)) continue;  // a zero cone (a path of length 0) gathers nothing
    if (c.radius >= cap) ++out.capped;
    if (c.specular > 0) ++out.behind_specular;
    out.radius_sum += c.radius;
    const pb::toolkit::BvhBox box =
        pb::toolkit::cylinder_box(c.position, c.normal, c.radius, 0.1f * c.radius);
    ++out.count;
    if (per_pixel) {
      out.point_of_pixel[path.pixel] = path.pixel;
      out.points[path.pixel] = c;
      out.boxes[path.pixel] = box;
      continue;
    }
    out.point_of_pixel[path.pixel] = uint32_t(out.points.size());
    out.points.push_back(c);
    out.boxes.push_back(box);
  }
}

void make_photons(std::span<const pb::trace::PhotonRecord> photons, const pb::SceneTriangles& scene,
                  std::vector<CpPhoton>& out) {
  out.resize(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) {
    const pb::trace::PhotonRecord& p = photons[i];
    CpPhoton& o = out[i];
    o = CpPhoton{};
    o.position = p.position;
    o.power = p.power;
    o.normal = p.normal;
    o.material = p.triangle < scene.triangle_count() ? scene.material(p.triangle) : CP_NONE;
  }
}

}  // namespace cp
