// Path tracing with next-event estimation and MIS (power heuristic, Veach 1997 ch. 9): the
// reference renderer's anchor among its unbiased estimators (reference.h), for every path that
// photon mapping does not own (path_space.h, photon_mapping_owns). Internal to reference/.
#pragma once

#include <tbb/combinable.h>
#include <tbb/task_arena.h>

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "reference/estimators.h"
#include "reference/path_space.h"
#include "trace/incident_light_tree.h"
#include "trace/lights.h"

namespace pb::trace::detail {

// One iteration over every pixel of the grid of `stride` (in_grid; every pixel: stride 1): one
// camera sample per pixel, its contributions by class written to frame[pixel * kClasses + c]
// (replacing what was there). Paths stop after `budget` scattering vertices and add only to the
// classes of `wanted`; the rays traced are counted in `ray_count`. Next-event estimation chooses
// its light through `tree` where given (its MIS densities too), else by power from `lights`.
void path_tracing_pass(const EmbreeScene& world, const LightSet& lights,
                       const IncidentLightTree* tree, const Rig& rig, LightStrategies strategies,
                       uint32_t wanted, uint32_t budget, uint32_t iteration_seed, int stride,
                       tbb::task_arena& arena, tbb::combinable<uint64_t>& ray_count,
                       std::vector<glm::vec3>& frame);

}  // namespace pb::trace::detail
