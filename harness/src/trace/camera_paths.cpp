#include "trace/camera_paths.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <cmath>

#include "photonbench/error.h"
#include "trace/bsdf.h"
#include "trace/sampling.h"

namespace pb::trace {

namespace {

glm::vec3 camera_ray_direction(const CameraPathCamera& camera, uint32_t x, uint32_t y) {
  const glm::vec2 ndc{2.f * (float(x) + 0.5f) / float(camera.width) - 1.f,
                      2.f * (float(y) + 0.5f) / float(camera.height) - 1.f};
  glm::vec4 near = camera.inverse_view_projection * glm::vec4(ndc, 0.f, 1.f);
  glm::vec4 far = camera.inverse_view_projection * glm::vec4(ndc, 1.f, 1.f);
  return glm::normalize(glm::vec3(far) / far.w - glm::vec3(near) / near.w);
}

// The origin of a ray leaving surface point `p` into `dir`: moved off the surface to the side
// `dir` goes, so that the ray does not find the surface it leaves.
glm::vec3 spawn_off_surface(const glm::vec3& p, const glm::vec3& geometric_normal,
                            const glm::vec3& dir) {
  const float eps = EmbreeScene::ray_epsilon(p);
  return p + geometric_normal * (glm::dot(dir, geometric_normal) >= 0 ? eps : -eps);
}

struct CameraPathWalker {
  const EmbreeScene& world;
  const CameraPathCamera& camera;
  uint32_t max_bounces;
  uint32_t seed;
  float spread;

  // Returns the segments traced.
  uint32_t trace(uint32_t pixel, CameraPathRecord& path) const {
    const scene::Scene& scene = world.scene();
    Pcg32 rng(seed, pixel);
    path = CameraPathRecord{};
    path.pixel = pixel;
    path.material = ~0u;
    path.throughput = glm::vec3(1.f);
    // The ray leaves `origin` (moved off the surface), the path's vertex is `vertex`: lengths and
    // the last segment are measured from the vertex itself.
    glm::vec3 vertex = camera.eye, origin = camera.eye;
    glm::vec3 dir = camera_ray_direction(camera, pixel % camera.width, pixel / camera.width);
    float travelled = 0;
    uint32_t specular = 0;
    for (uint32_t hits = 0;; ++hits) {
      path.segment_origin = vertex;
      path.segment_direction = dir;
      Hit hit;
      if (!world.intersect(origin, dir, kUnboundedRay, hit)) {
        path.segment_length = 0;
        path.flags = specular | PB_CAMERA_PATH_NO_DIFFUSE | PB_CAMERA_PATH_ESCAPED;
        return hits + 1;
      }
      const float length = glm::distance(vertex, hit.position);
      travelled += length;
      path.position = hit.position;
      path.segment_length = length;
      path.cone_width = spread * travelled;
      const bool towards = glm::dot(hit.geometric_normal, dir) > 0;
      path.normal = towards ? -hit.shading_normal : hit.shading_normal;
      if (world.is_light_object(hit.object)) {  // a luminaire's geometry absorbs what reaches it
        path.flags = specular | PB_CAMERA_PATH_NO_DIFFUSE;
        return hits + 1;
      }
      path.material = hit.material;
      const Bsdf bsdf(scene.materials[hit.material], hit);
      if (bsdf.is_diffuse()) {
        path.flags = specular;
        return hits + 1;
      }
      if (hits + 1 == max_bounces) {
        path.flags = specular | PB_CAMERA_PATH_NO_DIFFUSE | PB_CAMERA_PATH_BOUNCE_LIMIT;
        return hits + 1;
      }
      // An S vertex: the BSDF picks the lobe (a smooth dielectric reflects with probability F),
      // and the throughput takes its weight f |cos| / pdf.
      const glm::vec2 u2 = rng.next_2d();
      const glm::vec3 u{u2.x, u2.y, rng.next_float()};
      BsdfSample s;
      if (!bsdf.sample(-dir, u, Transport::radiance, s)) {
        path.flags = specular | PB_CAMERA_PATH_NO_DIFFUSE;
        return hits + 1;
      }
      ++specular;
      path.throughput *= s.weight;
      vertex = hit.position;
      origin = spawn_off_surface(hit.position, hit.geometric_normal, s.wi);
      dir = s.wi;
    }
  }
};

}  // namespace

float pixel_spread_angle(float fov_y, uint32_t height) {
  return std::atan(2.f * std::tan(0.5f * fov_y) / float(height));
}

void trace_camera_paths(const EmbreeScene& world, const CameraPathCamera& camera, uint32_t frame,
                        std::optional<uint32_t> seed_scramble, const CameraPathSettings& settings,
                        CameraPathBatch& out) {
  if (settings.max_bounces < 1 || settings.max_bounces > PB_CAMERA_PATH_SPECULAR_MASK)
    throw InputError(fmt::format("camera paths: max_bounces {} is outside [1, {}]",
                                 settings.max_bounces, PB_CAMERA_PATH_SPECULAR_MASK));
  const auto start = std::chrono::steady_clock::now();
  uint32_t seed = seed_scramble ? hash_combine(settings.seed, *seed_scramble) : settings.seed;
  if (settings.seed_per_frame) seed = hash_combine(seed, frame);
  const CameraPathWalker tracer{world, camera, settings.max_bounces, seed,
                                pixel_spread_angle(camera.fov_y, camera.height)};
  out.width = camera.width;
  out.height = camera.height;
  out.paths.resize(size_t(camera.width) * camera.height);
  std::atomic<uint64_t> rays{0};
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, camera.height),
                    [&](const tbb::blocked_range<uint32_t>& rows) {
                      uint64_t traced = 0;
                      for (uint32_t y = rows.begin(); y != rows.end(); ++y)
                        for (uint32_t x = 0; x < camera.width; ++x) {
                          const uint32_t p = y * camera.width + x;
                          traced += tracer.trace(p, out.paths[p]);
                        }
                      rays += traced;
                    });
  out.rays = rays;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace pb::trace
