// Bidirectional path tracing with multiple importance sampling (Veach 1997 ch. 10), the reference
// renderer's unbiased estimator for its part of path space (reference.h). Internal to reference/.
//
// Per pixel and iteration: one camera subpath z_0 (the pinhole) .. z_{t-1} and one light subpath
// y_0 (a point on an emitter) .. y_{s-1}; every pair of non-delta vertices z_{t-1}, y_{s-1} is
// connected by a shadow ray, and the strategies that need no shadow ray between subpath vertices
// are there too: s = 0 (the camera subpath hits an emitter), s = 1 (next-event estimation with a
// fresh light sample, as in path tracing) and t = 1 (the light subpath vertex is connected to the
// camera and splatted into the pixel it lands in: light tracing). Every full path x_0 .. x_k
// (camera to light) is weighted by the power heuristic over all strategies (s = 0..k) that can
// sample it.
//
// Densities for the weights are per unit area. A delta vertex (mirror, smooth glass) makes the
// density of its neighbours' generation a delta on both sides; that factor is set to 1 on both,
// and the strategies that would connect at the delta vertex are left out (their density is 0), so
// the weights still sum to 1 over the strategies that remain. Russian roulette probabilities are
// not in the densities: the weights still sum to 1, only a little less well balanced.
//
// The path's class (reference.h) comes from its vertex types read from the camera, whichever
// strategy produced it; paths in photon mapping's part of path space (photon_mapping_owns) and
// paths with more than the bounce budget's scattering vertices are left out, so the sum over
// strategies is exactly the integral over the rest.
#pragma once

#include <tbb/combinable.h>
#include <tbb/task_arena.h>

#include <cstdint>
#include <vector>

#include "reference/path_space.h"
#include "trace/lights.h"

namespace pb::trace::detail {

class BdptPass {
 public:
  BdptPass(const EmbreeScene& world, const LightSet& lights, const Rig& rig, uint32_t wanted,
           uint32_t budget, MisHeuristic heuristic = MisHeuristic::power);
  // One iteration: each pixel's contributions by class are written to frame[pixel * kClasses + c]
  // (replacing what was there), light tracing splats included; returns the rays traced. With
  // stride > 1 only the pixels of a grid of every stride-th pixel in x and y are rendered, with
  // their light paths (the pilot of Estimator::automatic): a splat then stands for the stride^2
  // light paths of a full iteration (unbiased, with stride^2 times the variance), and goes to
  // *splat_frame when given (replacing what was there), so that the pilot can tell the two apart.
  uint64_t run(uint32_t iteration_seed, tbb::task_arena& arena,
               tbb::combinable<uint64_t>& ray_count, std::vector<glm::vec3>& frame, int stride = 1,
               std::vector<glm::vec3>* splat_frame = nullptr);

 private:
  const EmbreeScene& world_;
  const LightSet& lights_;
  const Rig& rig_;
  uint32_t wanted_, budget_;
  MisHeuristic heuristic_;
};

}  // namespace pb::trace::detail
