#include "reference/reference.h"

#include <fmt/format.h>
#include <tbb/combinable.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "io/clock.h"
#include "photonbench/error.h"
#include "reference/accumulator.h"
#include "reference/bdpt.h"
#include "reference/estimator_pilot.h"
#include "reference/path_space.h"
#include "reference/path_tracing_pass.h"
#include "reference/photon_mapping_pass.h"
#include "trace/incident_light_tree.h"
#include "trace/lights.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace {

using namespace detail;

constexpr std::string_view kStopRuleNames[] = {"rel_error", "max_seconds", "samples"};

}  // namespace

std::string_view stop_rule_name(StopRule rule) { return kStopRuleNames[int(rule)]; }
std::optional<StopRule> parse_stop_rule(std::string_view name) {
  for (int r = 0; r < 3; ++r)
    if (kStopRuleNames[r] == name) return StopRule(r);
  return std::nullopt;
}

CameraRay camera_ray(const scene::Camera& camera, int width, int height, float px, float py) {
  Rig rig(camera, width, height);
  return {rig.position, rig.direction(px, py)};
}

ReferenceResult render_reference_classes(const EmbreeScene& world, int width, int height,
                                         uint32_t class_mask, const ReferenceOptions& options,
                                         const ProgressFn& progress) {
  if (width <= 0 || height <= 0)
    throw InputError(fmt::format("reference: bad resolution {}x{}", width, height));
  if (class_mask == 0 || (class_mask & ~kAllPathClasses))
    throw InputError("reference: no path class requested");
  options.validate();
  auto t0 = std::chrono::steady_clock::now();
  const scene::Scene& scene = world.scene();
  LightSet lights(world);
  Rig rig(world.state().camera, width, height);
  uint32_t wanted = class_mask & class_bit(PathClass::combined) ? kAllPathClasses : class_mask;
  uint32_t budget = bounce_budget(options.max_bounces);
  // Photon mapping has work when photons can add to a wanted class (any but `direct`) in a scene
  // with specular surfaces (without them its part of path space is empty), and when paths may have
  // the two scattering vertices (L S D) its paths need at least.
  uint32_t photon_classes = class_bit(PathClass::indirect) | class_bit(PathClass::caustics) |
                            class_bit(PathClass::indirect_caustics) |
                            class_bit(PathClass::specular);
  bool use_photons =
      (wanted & photon_classes) && scene_has_specular(scene) && lights.size() > 0 && budget >= 2;

  size_t pixels = size_t(width) * height;
  std::vector<glm::vec3> frame(pixels * kClasses);
  auto acc = std::make_unique<Accumulator>(pixels, class_mask);
  auto arena = options.threads > 0 ? std::make_unique<tbb::task_arena>(options.threads)
                                   : std::make_unique<tbb::task_arena>();
  tbb::combinable<uint64_t> ray_count([] { return uint64_t(0); });
  std::unique_ptr<PhotonMappingPass> photons;
  if (use_photons)
    photons =
        std::make_unique<PhotonMappingPass>(world, rig, options.photon_mapping, wanted, budget);
  auto total_rays = [&] {
    uint64_t rays = photons ? photons->photon_rays() : 0;
    ray_count.combine_each([&](uint64_t r) { rays += r; });
    return rays;
  };
  // The automatic choice pilots (EstimatorPilot) on an image of at least 9 times the pilot's
  // pixels, whatever the stop rule: a render of a fixed number of samples is piloted as one with an
  // error target is, and the pilot's budget (kPilotBudget of the render) keeps it short where the
  // render is. Smaller images are bidirectional: a grid of every pixel would cost a pilot a whole
  // bidirectional iteration per step.
  Estimator estimator = options.estimator;
  // Path tracing's light choice (LightSelection): the light tree where asked.
  std::unique_ptr<IncidentLightTree> light_tree;
  if (estimator != Estimator::bdpt && options.light_selection == LightSelection::bvh)
    light_tree = std::make_unique<IncidentLightTree>(world, lights);
  std::unique_ptr<BdptPass> bdpt;
  if (estimator != Estimator::pt)
    bdpt = std::make_unique<BdptPass>(world, lights, rig, wanted, budget, options.mis_heuristic);
  PilotReport report;
  std::unique_ptr<EstimatorPilot> pilot;
  if (estimator == Estimator::automatic) {
    bool worth = pilot_stride(pixels) >= 3;
    if (worth)
      pilot =
          std::make_unique<EstimatorPilot>(rig, options, acc->classes(), *bdpt, *arena, ray_count);
    else
      report.why = "bidirectional: the image is too small for the pilot's grid (stride under 3)";
    estimator = worth ? Estimator::pt : Estimator::bdpt;
  } else {
    report.why = "asked for";
  }

  double rel_error = 0, radius_scale2 = 1;
  StopRule stopped_by = StopRule::samples;
  for (uint32_t it = 0;; ++it) {
    uint32_t iteration_seed = hash_combine(options.seed, it);
    uint64_t rays_before = pilot ? total_rays() : 0;
    // ---- the unbiased estimator: one camera sample per pixel ----
    if (estimator == Estimator::bdpt)
      bdpt->run(iteration_seed, *arena, ray_count, frame);
    else
      path_tracing_pass(world, lights, light_tree.get(), rig, options.light_strategies, wanted,
                        budget, iteration_seed, 1, *arena, ray_count, frame);
    if (pilot) pilot->observe(Pilot::path_tracing, frame, total_rays() - rays_before);
    // ---- photon mapping: visible points, photons, gather ----
    if (photons) {
      if (it > 0) radius_scale2 *= (it + options.photon_mapping.alpha) / (it + 1.0);
      uint64_t photon_rays_before = total_rays();
      photons->run(iteration_seed, radius_scale2, *arena, ray_count, frame);
      if (pilot) pilot->observe(Pilot::photons, frame, total_rays() - photon_rays_before);
    }
    acc->add(it, frame, *arena);
    // ---- stop rules: the first reached ends the render ----
    uint32_t done = acc->iterations();
    double elapsed = io::seconds_since(t0);
    bool stop = false;
    if (done % 2 == 0 && done > 0) {  // the error and time rules stop on even counts
      if (options.rel_error > 0 && done >= std::max(2u, options.min_samples)) {
        rel_error = acc->rel_error();
        if (rel_error <= options.rel_error) stop = true, stopped_by = StopRule::rel_error;
      }
      if (!stop && options.max_seconds > 0 && elapsed >= options.max_seconds)
        stop = true, stopped_by = StopRule::max_seconds;
    }
    if (!stop && options.samples > 0 && done >= options.samples)
      stop = true, stopped_by = StopRule::samples;
    if (progress)
      progress({done, options.samples, rel_error, options.rel_error, elapsed, options.max_seconds,
                total_rays()});
    if (stop) break;
    // ---- the automatic choice: bidirectional path tracing restarts the render ----
    if (pilot) {
      if (std::optional<Estimator> chosen = pilot->step(acc->iterations())) {
        report = pilot->report();
        pilot.reset();
        estimator = *chosen;
        if (estimator == Estimator::bdpt) {
          report.dropped_iterations = acc->iterations();
          acc = std::make_unique<Accumulator>(pixels, class_mask);
          radius_scale2 = 1;
          it = std::numeric_limits<uint32_t>::max();  // the next iteration is 0
        }
      }
    }
  }

  if (pilot) {  // the render ended while the pilot still ran
    report = pilot->report();
    report.why = "path tracing: the render ended before the pilot decided";
  }

  // ---- resolve ----
  ReferenceResult result;
  result.samples = acc->iterations();
  result.photon_paths = photons ? photons->photon_paths() : 0;
  result.seed = options.seed;
  result.rel_error = acc->rel_error();
  result.stopped_by = stopped_by;
  result.estimator = estimator;
  result.light_selection =
      estimator == Estimator::pt && light_tree ? LightSelection::bvh : LightSelection::power;
  result.pilot = report;
  result.rays = total_rays();
  result.seconds = io::seconds_since(t0);
  for (size_t j = 0; j < acc->classes().size(); ++j) {
    ReferenceImage& img = result.classes[acc->classes()[j]];
    acc->resolve(j, width, height, img.mean, img.variance, img.half);
    img.samples = result.samples;
    img.seed = options.seed;
    img.seconds = result.seconds;
    img.rel_error = result.rel_error;
    img.stopped_by = stopped_by;
    img.max_bounces = options.max_bounces;
    img.estimator = estimator;
  }
  return result;
}

ReferenceImage render_reference(const scene::Scene& scene, const scene::FrameState& state,
                                PathClass path_class, int width, int height,
                                const ReferenceOptions& options, const ProgressFn& progress) {
  EmbreeScene world(scene, state, one_frame_options());
  ReferenceResult r =
      render_reference_classes(world, width, height, class_bit(path_class), options, progress);
  return std::move(r.classes[int(path_class)]);
}

}  // namespace pb::trace
