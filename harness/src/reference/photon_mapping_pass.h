// Progressive photon mapping in its probabilistic form (Knaus & Zwicker 2011): the reference
// renderer's estimator for the paths it owns (path_space.h, photon_mapping_owns: a diffuse vertex
// whose vertex next to the light is specular). Every iteration is an independent photon-map
// estimate at fresh visible points (the first diffuse camera vertex, C S* D) with fresh photons
// (those whose first interaction was specular), the radius shrinking from one iteration to the
// next. Internal to reference/.
#pragma once

#include <tbb/combinable.h>
#include <tbb/task_arena.h>

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "reference/estimators.h"
#include "reference/path_space.h"
#include "trace/photon_tracer.h"

namespace pb::trace::detail {

// Whether any object's material is specular (mirror, glass, rough): without one, photon mapping's
// part of path space is empty.
bool scene_has_specular(const scene::Scene& scene);

struct VisiblePoint {
  glm::vec3 position{0.0f}, normal{0.0f}, wo{0.0f}, beta{0.0f}, albedo{0.0f};
  float distance = 0;            // camera path length, for the automatic initial radius
  uint32_t specular_prefix = 0;  // specular vertices before it (C S^k D)
  bool valid = false;
};

class PhotonGrid;

// What one iteration of photon mapping needs across iterations: the visible points are redrawn
// every iteration (new jitter, new specular choices), so nothing but scratch memory is kept and the
// iterations stay independent.
class PhotonMappingPass {
 public:
  PhotonMappingPass(const EmbreeScene& world, const Rig& rig, const PhotonMappingOptions& options,
                    uint32_t wanted, uint32_t budget);

  // Iteration `i` (1-based) of Knaus & Zwicker 2011: an independent photon-map estimate whose
  // squared radius is r_1^2 prod_{j<i} (j + alpha) / (j + 1) (their eq. 20; `radius_scale2` is
  // that product), so that the variance grows and the blur bias shrinks just fast enough for the
  // average over iterations to converge. Adds each pixel's estimate into
  // frame[pixel * kClasses + class]. With stride > 1 only the pilot's grid of pixels (in_grid)
  // gets visible points, and `paths` (0: options.photons) photon paths are traced.
  void run(uint32_t iteration_seed, double radius_scale2, tbb::task_arena& arena,
           tbb::combinable<uint64_t>& ray_count, std::vector<glm::vec3>& frame, int stride = 1,
           uint32_t paths = 0);

  uint64_t photon_rays() const { return photon_rays_; }
  uint64_t photon_paths() const { return photon_paths_; }

 private:
  void aim_emission(tbb::task_arena& arena);
  void gather(const PhotonGrid& grid, size_t i, std::vector<glm::vec3>& frame) const;

  const EmbreeScene& world_;
  EmbreePhotonTracer tracer_;
  const Rig& rig_;
  const PhotonMappingOptions& options_;
  uint32_t wanted_, budget_;
  float pixel_angle_;  // footprint per metre of distance
  std::vector<VisiblePoint> vps_;
  std::vector<float> radius2_;
  uint64_t photon_rays_ = 0, photon_paths_ = 0;
  bool emission_set_ = false;  // aimed emission's densities handed to the tracer (first run)
};

}  // namespace pb::trace::detail
