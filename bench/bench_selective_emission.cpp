// bench_selective_emission: the rays per frame of seed 001's selective photon emission (thesis
// Ch. 9; photonbench/toolkit/selective_emission.h) against re-tracing every path of the same fixed
// Halton emission points, over an animation, and what the selection leaves stale: paths whose kept
// version is not what a fresh trace of the frame gives (they wait for their group's probe), and the
// share of the per-surface energy that differs from the fresh trace's.
//
//   bench_selective_emission [--scene scenes/walker.yaml] [--first 0] [--frames 40]
//                            [--group-size 40] [--tolerance 0.001] [--max-bounces 8]
//
// The first frame traces everything (both columns equal); the summary is over the others. Counts,
// not times: both sides trace on the same tracer and scene, so rays are the cost.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "bench_support.h"
#include "photonbench/photons.h"
#include "photonbench/toolkit/selective_emission.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

namespace {

int run(int argc, char** argv) {
  const std::filesystem::path source_dir = PB_SOURCE_DIR;  // __FILE__ is relative under ccache
  auto options = pb::bench::parse_options(
      argc, argv,
      {{"--scene", (source_dir / "scenes/walker.yaml").string()},
       {"--first", "0"},
       {"--frames", "40"},
       {"--group-size", "40"},
       {"--tolerance", "0.001"},
       {"--max-bounces", "8"}},
      "bench_selective_emission [--scene FILE] [--first F] [--frames N] [--group-size N] "
      "[--tolerance METRES] [--max-bounces N]");
  if (!options) return 2;
  auto& opt = *options;
  const uint32_t first = uint32_t(std::stoul(opt["--first"]));
  const uint32_t frames = uint32_t(std::stoul(opt["--frames"]));

  pb::scene::Scene scene = pb::scene::load_scene(opt["--scene"]);
  pb::trace::EmbreeScene world(scene, scene.at(first));
  pb::trace::EmbreePhotonTracer tracer(world);
  pb::toolkit::SelectiveEmissionSettings settings;
  settings.group_size = uint32_t(std::stoul(opt["--group-size"]));
  settings.divergence_tolerance = std::stof(opt["--tolerance"]);
  settings.trace.max_bounces = uint32_t(std::stoul(opt["--max-bounces"]));
  settings.trace.store = pb::trace::kAllPhotons;
  pb::toolkit::SelectiveEmission selective(tracer, settings);

  // Re-tracing all paths: the same emission points and samples, every frame.
  pb::toolkit::HaltonGroupEmission all(settings.halton_bases, settings.group_size);
  pb::trace::TraceSettings full = settings.trace;
  full.emission = &all;
  full.keep_light_paths = true;
  full.seed_per_frame = false;

  std::printf(
      "bench_selective_emission: %s, frames %u..%u, %u lights x %u groups x %u photons, "
      "tolerance %s m, max_bounces %u\n",
      scene.name.c_str(), first, first + frames - 1, tracer.light_count(), all.group_count(),
      settings.group_size, opt["--tolerance"].c_str(), settings.trace.max_bounces);
  std::printf("%6s %7s %8s %9s %10s %10s %7s %12s %11s\n", "frame", "probes", "invalid", "retraced",
              "rays sel", "rays all", "ratio", "stale paths", "stale energy");
  uint64_t rays_selective = 0, rays_all = 0, stale_sum = 0;
  double stale_energy_sum = 0;
  for (uint32_t f = first; f < first + frames; ++f) {
    world.update(scene.at(f));
    const pb::toolkit::SelectiveEmissionStats s = selective.update();
    pb::trace::PhotonBatch batch;
    const pb::trace::TraceStats t = tracer.trace(full, batch);
    // Stale paths: a kept path that differs from this frame's fresh one.
    uint64_t stale = 0;
    for (uint32_t p = 0; p < selective.path_count(); ++p) {
      const pb::trace::LightPath& lp = batch.paths.paths[p];
      const auto kept = selective.path_vertices(p);
      bool same = kept.size() == lp.vertex_count;
      for (uint32_t k = 0; same && k < lp.vertex_count; ++k) {
        const pb::trace::PathVertex& v = batch.paths.vertices[lp.first_vertex + k];
        same = v.object == kept[k].object && v.position == kept[k].position;
      }
      stale += !same;
    }
    // Stale energy: sum over surfaces of |kept - fresh| against the fresh total (RGB summed).
    pb::toolkit::SurfaceEnergyLedger fresh({}, selective.ledger().units_per_watt());
    for (const auto& ph : batch.photons) fresh.add(ph);
    const size_t surfaces = std::max(fresh.units().size(), selective.ledger().units().size());
    double differ = 0, total = 0;
    for (uint32_t sfc = 0; sfc < surfaces; ++sfc) {
      const glm::dvec3 a = selective.ledger().watts(sfc), b = fresh.watts(sfc);
      differ += std::abs(a.x - b.x) + std::abs(a.y - b.y) + std::abs(a.z - b.z);
      total += b.x + b.y + b.z;
    }
    const double stale_energy = total > 0 ? differ / total : 0;
    std::printf("%6u %7llu %8llu %9llu %10llu %10llu %7.3f %12llu %10.3f%%\n", f,
                (unsigned long long)s.probes, (unsigned long long)s.groups_invalidated,
                (unsigned long long)s.paths_retraced, (unsigned long long)s.rays(),
                (unsigned long long)t.rays, double(s.rays()) / double(t.rays),
                (unsigned long long)stale, 100 * stale_energy);
    if (f == first) continue;
    rays_selective += s.rays();
    rays_all += t.rays;
    stale_sum += stale;
    stale_energy_sum += stale_energy;
  }
  if (frames > 1) {
    const double n = frames - 1;
    std::printf(
        "frames %u..%u: rays per frame %.0f (selective) against %.0f (all paths), %.3f; stale "
        "paths per frame %.1f of %u, stale energy %.3f%%\n",
        first + 1, first + frames - 1, rays_selective / n, rays_all / n,
        double(rays_selective) / double(rays_all), stale_sum / n, selective.path_count(),
        100 * stale_energy_sum / n);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_selective_emission: %s\n", e.what());
    return 1;
  }
}
