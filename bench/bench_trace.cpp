// bench_trace: ray throughput of our Embree path tracer (the reference renderer) next to Embree's
// own `pathtracer` tutorial (Debian package embree-tools) on the same triangles and camera, as a
// ratio (target: at least 1.0x), plus the photon tracer's throughput on the same scene, traced in
// the same alternating rounds without and with footprints, its cost per ray over the path
// tracer's (the median of the per-round ratios; target at most 1.3x) and what the footprints
// cost; and the photon tracer's own rays replayed through Embree alone, which splits that ratio
// into Embree's cost on those rays and our code around the queries. `--pathtracer none` leaves
// the tutorial out.
// The tutorial's OBJ materials are diffuse (Kd) and its light here is one point light, so both
// renderers get the scene as the tutorial can render it (make_comparable): every material diffuse
// with its albedo, and the lights replaced by one point light of their total power at the first
// light's position; the header names what was replaced. Both build the scene for the one frame,
// every rigid object in one BVH (the tutorial's OBJ is one static scene).
//
//   bench_trace [--scene scenes/cornell-box.yaml] [--spp 8] [--depth 8] [--frames 7]
//               [--pathtracer PATH] [--estimator pt|bdpt|auto]
//
// The scene's triangles are written in world space to an OBJ (+ MTL with Kd) in a temporary
// directory; the tutorial renders it at 640x360 with the same camera (--vp/--vi/--vu/--fov,
// vertical fov), the same samples per pixel and path length, and reports Mrays/s from its own ray
// counters (BENCHMARK_RENDER_MRAYPS_AVG of --benchmark). Both sides count every ray they trace,
// closest-hit and shadow alike, and both use all hardware threads; they run in alternating rounds
// and the ratio is the median of the per-round ratios. Ours is the whole render of
// render_reference_classes (its per-pixel accumulation included), by default with path tracing and
// next-event estimation, the tutorial's own algorithm: the reference renderer's automatic choice
// picks bidirectional path tracing for a render this short, whose rays cost more each (its
// Mrays/s are 0.5-0.8 of path tracing's, harness/src/reference/README.md), and which this bench
// measured from the estimators' landing until the wavefront (0.48x).
#include <fmt/format.h>
#include <malloc.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glm/glm.hpp>
#include <map>
#include <string>
#include <vector>

#include "bench_support.h"
#include "photonbench/photons.h"
#include "reference/reference.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/lights.h"
#include "trace/photon_paths.h"
#include "trace/photon_tracer.h"

namespace fs = std::filesystem;

namespace {

void write_obj(const pb::scene::Scene& scene, const pb::scene::FrameState& state,
               const fs::path& dir) {
  std::ofstream mtl(dir / "scene.mtl");
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    const auto& mat = scene.materials[m];
    mtl << fmt::format("newmtl m{}\nKd {} {} {}\n", m, mat.albedo.x, mat.albedo.y, mat.albedo.z);
  }
  std::ofstream obj(dir / "scene.obj");
  obj << "mtllib scene.mtl\n";
  size_t base = 1;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const auto& mesh = scene.objects[o].mesh;
    glm::mat4 m = o < state.object_to_world.size() ? state.object_to_world[o] : glm::mat4(1.f);
    glm::mat3 nm = glm::transpose(glm::inverse(glm::mat3(m)));
    obj << fmt::format("o {}\nusemtl m{}\n", scene.objects[o].name, scene.objects[o].material);
    for (const auto& p : mesh.positions) {
      glm::vec3 w = glm::vec3(m * glm::vec4(p, 1.f));
      obj << fmt::format("v {} {} {}\n", w.x, w.y, w.z);
    }
    for (const auto& n : mesh.normals) {
      glm::vec3 w = glm::normalize(nm * n);
      obj << fmt::format("vn {} {} {}\n", w.x, w.y, w.z);
    }
    bool normals = mesh.normals.size() == mesh.positions.size();
    for (const auto& t : mesh.triangles) {
      if (normals)
        obj << fmt::format("f {0}//{0} {1}//{1} {2}//{2}\n", t.x + base, t.y + base, t.z + base);
      else
        obj << fmt::format("f {} {} {}\n", t.x + base, t.y + base, t.z + base);
    }
    base += mesh.positions.size();
  }
}

// Makes `scene` at `state` what the tutorial renders (see the top of the file); returns what
// changed.
std::string make_comparable(pb::scene::Scene& scene, pb::scene::FrameState& state) {
  using pb::scene::LightType;
  using pb::scene::MaterialType;
  // Every emitter's power (lights and emissive surfaces), read before the materials lose their
  // emission below.
  glm::vec3 power(0.f);
  uint32_t emitters = 0;
  {
    pb::trace::EmbreeScene original(scene, state, pb::trace::one_frame_options());
    pb::trace::LightSet lights(original);
    emitters = lights.size();
    for (uint32_t i = 0; i < emitters; ++i) power += lights.emitter(i).power;
  }
  std::string changed;
  int made_diffuse = 0;
  for (auto& m : scene.materials) {
    if (m.type == MaterialType::diffuse && m.emission == glm::vec3(0.f)) continue;
    ++made_diffuse;
    m.type = MaterialType::diffuse;
    m.emission = glm::vec3(0.f);
    if (m.albedo == glm::vec3(0.f)) m.albedo = glm::vec3(0.5f);
  }
  if (made_diffuse) changed += fmt::format("{} material(s) made diffuse; ", made_diffuse);
  bool single_point =
      emitters == 1 && state.lights.size() == 1 && state.lights[0].type == LightType::point;
  if (!single_point) {
    changed += fmt::format("{} emitter(s) replaced by one point light of their power; ", emitters);
    pb::scene::Light point;
    point.name = "comparable";
    point.type = LightType::point;
    point.position = state.lights.empty() ? glm::vec3(0.f, 1.f, 0.f) : state.lights[0].position;
    point.radiant = power == glm::vec3(0.f) ? glm::vec3(1.f) : power / (4.f * float(M_PI));
    state.lights = {point};
    scene.lights.resize(1);
    scene.lights[0].light = point;
  }
  return changed.empty() ? "as it is" : changed.substr(0, changed.size() - 2);
}

double parse_value(const std::string& text, const std::string& key) {
  size_t at = text.find(key + " ");
  if (at == std::string::npos) return -1;
  return std::atof(text.c_str() + at + key.size() + 1);
}

std::string find_pathtracer() {
  for (const char* p : {"/usr/bin/pathtracer", "/usr/local/bin/pathtracer"})
    if (fs::exists(p)) return p;
  std::string listed =
      pb::bench::run_capture("dpkg -L embree-tools 2>/dev/null | grep '/pathtracer$' | head -n1");
  while (!listed.empty() && (listed.back() == '\n' || listed.back() == '\r')) listed.pop_back();
  return listed;
}

// The segments the photon tracer traced, rebuilt from its kept light paths: from each vertex
// that has a successor (its segment hit it) or that escaped (its segment hit nothing), the ray
// continue_path gave Embree. Exact for a trace without a policy (no split part starts a vertex
// without a segment); the caller checks the count against the trace's own.
std::vector<pb::trace::Ray> traced_segments(const pb::trace::LightPaths& paths) {
  std::vector<pb::trace::Ray> rays;
  for (const auto& path : paths.paths)
    for (uint32_t i = 0; i < path.vertex_count; ++i) {
      const pb::trace::PathVertex& v = paths.vertices[path.first_vertex + i];
      if (i + 1 < path.vertex_count || (v.flags & pb::trace::PathVertex::kEscapes))
        rays.push_back({pb::trace::detail::spawn_origin(v), v.direction});
    }
  return rays;
}

// Seconds Embree (with our hit completion, EmbreeScene::intersect) takes for `rays` on every
// hardware thread: one call a ray, as the photon tracer traces them, or as streams of
// `stream_size` (intersect_stream, incoherent).
double replay_seconds(const pb::trace::EmbreeScene& world, const std::vector<pb::trace::Ray>& rays,
                      size_t stream_size) {
  auto t0 = std::chrono::steady_clock::now();
  const size_t chunk = 256;
  tbb::parallel_for(size_t(0), (rays.size() + chunk - 1) / chunk, [&](size_t c) {
    const size_t begin = c * chunk, end = std::min(rays.size(), begin + chunk);
    std::array<pb::trace::Hit, chunk> hits;
    std::array<uint8_t, chunk> found;
    if (stream_size == 1) {
      for (size_t i = begin; i < end; ++i)
        world.intersect(rays[i].origin, rays[i].dir, rays[i].tmax, hits[i - begin]);
      return;
    }
    for (size_t s = begin; s < end; s += stream_size) {
      const size_t n = std::min(stream_size, end - s);
      world.intersect_stream(std::span(rays).subspan(s, n), std::span(hits).subspan(s - begin, n),
                             std::span(found).subspan(s - begin, n), false);
    }
  });
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  // Both tracers run in this one process: with glibc's defaults, which of them faults in fresh
  // pages each round depends on what the other freed last (its dynamic mmap threshold and heap
  // trimming), so a change to one moved the other's rate (a photon tracer that kept its batch
  // memory made the path tracer's buffers fault in afresh: 1.5x its time on cornell-box). Memory
  // freed stays in the heap, and blocks up to the largest threshold come from it: every round
  // after the warm-up measures the rays, not the page faults the other side caused.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  const fs::path source_dir = pb::bench::source_dir();
  auto options = pb::bench::parse_options(
      argc, argv,
      {{"--scene", (source_dir / "scenes/cornell-box.yaml").string()},
       {"--spp", "8"},
       {"--depth", "8"},
       {"--frames", "7"},
       {"--pathtracer", ""},
       {"--estimator", "pt"},
       {"--photon-paths", "500000"}},
      "bench_trace [--scene FILE] [--spp N] [--depth N] [--frames N] [--pathtracer PATH|none] "
      "[--estimator pt|bdpt|auto] [--photon-paths N]");
  if (!options) return 2;
  auto& opt = *options;
  const int width = 640, height = 360;
  const uint32_t spp = uint32_t(std::stoul(opt["--spp"])),
                 depth = uint32_t(std::stoul(opt["--depth"]));
  const int frames = std::stoi(opt["--frames"]);
  auto estimator = pb::trace::parse_estimator(opt["--estimator"]);
  if (!estimator) {
    std::fprintf(stderr, "bench_trace: --estimator must be pt, bdpt or auto\n");
    return 2;
  }

  pb::scene::Scene scene = pb::scene::load_scene(opt["--scene"]);
  pb::scene::FrameState state = scene.at(0);
  std::string comparable = make_comparable(scene, state);
  pb::trace::EmbreeScene world(scene, state, pb::trace::one_frame_options());
  size_t triangles = 0;
  for (const auto& o : scene.objects) triangles += o.mesh.triangle_count();
  std::printf("bench_trace: %s, %zu triangles, %dx%d, %u spp, max path length %u, estimator %s\n",
              scene.name.c_str(), triangles, width, height, spp, depth, opt["--estimator"].c_str());
  std::printf("scene for both renderers: %s\n", comparable.c_str());
  std::printf("vector units: %s\n", pb::bench::vector_units().c_str());

  // ---- the photon tracer on the same scene: every diffuse hit stored, the tracer's own decisions
  // (no policy, so no footprint hooks), without footprints as most techniques trace, a fresh seed
  // each round ----
  pb::trace::EmbreePhotonTracer tracer(world);
  pb::trace::TraceSettings ts;
  ts.paths = uint32_t(std::stoul(opt["--photon-paths"]));
  ts.store = pb::trace::kAllPhotons;
  ts.seed_per_frame = false;
  pb::trace::PhotonBatch batch;
  tracer.trace(ts, batch);  // warm-up: faults the batch's memory in
  // The same trace with ray differentials and footprints, as AAPS and photon differentials ask.
  pb::trace::TraceSettings ts_footprints = ts;
  ts_footprints.footprints = true;
  std::vector<double> photon_rates, photon_cost_ratios, footprint_rates, footprint_cost_ratios;
  double photon_rays_per_path = 0;
  // The photon tracer's own rays, replayed through Embree alone: what its cost per ray would be
  // with nothing of ours around the queries. Its rays are incoherent (emission over the sphere,
  // diffuse bounces), where the path tracer's first segments are the camera's coherent rows and
  // its shadow rays end at any hit: Embree's own cost per ray differs between the two before any
  // of our code runs, and this splits the ratio into that and ours.
  std::vector<pb::trace::Ray> photon_rays;
  {
    pb::trace::TraceSettings keep = ts;
    keep.keep_light_paths = true;
    pb::trace::PhotonBatch kept;
    const pb::trace::TraceStats stats = tracer.trace(keep, kept);
    photon_rays = traced_segments(kept.paths);
    if (photon_rays.size() != stats.rays) {
      std::fprintf(stderr, "bench_trace: rebuilt %zu segments of the photon trace's %llu rays\n",
                   photon_rays.size(), static_cast<unsigned long long>(stats.rays));
      return 1;
    }
    replay_seconds(world, photon_rays, 1);  // warm-up
  }
  std::vector<double> replay_rates, replay_stream_rates, replay_shares;

  // ---- ours (the reference path tracer, NEE + MIS), Embree's tutorial and the photon tracer, in
  // ---- alternating rounds. The machine may be shared: alternating them and taking the median of
  // per-round ratios keeps a load change from favouring whichever side ran during it.
  fs::path dir = fs::temp_directory_path() / fmt::format("pb_bench_trace_{}", ::getpid());
  fs::create_directories(dir);
  write_obj(scene, state, dir);
  std::string pathtracer = opt["--pathtracer"].empty() ? find_pathtracer() : opt["--pathtracer"];
  if (pathtracer == "none")
    pathtracer.clear();
  else if (pathtracer.empty())
    std::printf("embree pathtracer not found (install embree-tools); no ratio\n");
  const auto& c = state.camera;
  glm::vec3 light = state.lights[0].position, power = state.lights[0].radiant;
  std::string cmd = fmt::format(
      "cd '{}' && '{}' -i scene.obj --vp {} {} {} --vi {} {} {} --vu {} {} {} --fov {} --size {} "
      "{} --spp {} "
      "--max-path-length {} --pointlight {} {} {} {} {} {} --benchmark 1 2 2>&1",
      dir.string(), pathtracer, c.position.x, c.position.y, c.position.z, c.target.x, c.target.y,
      c.target.z, c.up.x, c.up.y, c.up.z, glm::degrees(c.fov_y), width, height, spp, depth, light.x,
      light.y, light.z, power.x, power.y, power.z);

  pb::trace::ReferenceOptions o;
  o.samples = spp;
  o.estimator = *estimator;
  o.max_bounces = depth;  // scattering vertices, as the tutorial's path length
  auto mask = pb::trace::class_bit(pb::trace::PathClass::combined);
  pb::trace::render_reference_classes(world, width, height, mask, o);  // warm-up
  std::vector<double> ours, theirs_rates, ratios;
  // Rays a camera path (paths of different lengths spread the per-path work over different counts).
  const double paths = double(width) * height * spp;
  double our_rays_per_path = 0, their_rays_per_path = 0;
  for (int f = 0; f < frames; ++f) {
    o.seed = uint32_t(f + 2);
    pb::trace::ReferenceResult r =
        pb::trace::render_reference_classes(world, width, height, mask, o);
    double mine = r.mrays_per_second();
    ours.push_back(mine);
    our_rays_per_path = double(r.rays) / paths;
    ts.seed = uint32_t(f + 2);
    pb::trace::TraceStats photon_stats = tracer.trace(ts, batch);
    photon_rates.push_back(photon_stats.mrays_per_second());
    photon_rays_per_path = double(photon_stats.rays) / double(photon_stats.paths);
    // Cost per ray: the photon tracer's seconds a ray over the path tracer's.
    photon_cost_ratios.push_back(mine / photon_rates.back());
    const double replayed = double(photon_rays.size()) * 1e-6;
    replay_rates.push_back(replayed / replay_seconds(world, photon_rays, 1));
    replay_stream_rates.push_back(replayed / replay_seconds(world, photon_rays, 64));
    // Embree's share of the photon tracer's cost per ray (its rays of this round's seed differ
    // from the replayed ones only in their random numbers).
    replay_shares.push_back(photon_rates.back() / replay_rates.back());
    ts_footprints.seed = ts.seed;
    footprint_rates.push_back(tracer.trace(ts_footprints, batch).mrays_per_second());
    footprint_cost_ratios.push_back(photon_rates.back() / footprint_rates.back());
    if (pathtracer.empty()) continue;
    std::string out = pb::bench::run_capture(cmd);
    double theirs = parse_value(out, "BENCHMARK_RENDER_MRAYPS_AVG");
    if (theirs <= 0) {
      std::printf("could not read the tutorial's Mrays/s; its output:\n%s\n", out.c_str());
      pathtracer.clear();
      continue;
    }
    theirs_rates.push_back(theirs);
    double fps = parse_value(out, "BENCHMARK_RENDER_AVG");  // frames (of spp samples) a second
    if (fps > 0) their_rays_per_path = theirs * 1e6 / fps / paths;
    ratios.push_back(mine / theirs);
  }
  fs::remove_all(dir);
  using pb::bench::median;
  double ours_median = median(ours), theirs = median(theirs_rates);

  std::printf("%-34s %10s %14s\n", "", "Mrays/s", "rays a path");
  std::printf("%-34s %10.2f %14.2f\n", "photonbench reference path tracer", ours_median,
              our_rays_per_path);
  if (theirs > 0)
    std::printf("%-34s %10.2f %14.2f\n", "embree pathtracer tutorial", theirs, their_rays_per_path);
  std::printf("%-34s %10.2f %14.2f\n", "photonbench photon tracer", median(photon_rates),
              photon_rays_per_path);
  std::printf("%-34s %10.2f %14.2f\n", "photonbench photon tracer, footprints",
              median(footprint_rates), photon_rays_per_path);
  std::printf("%-34s %10.2f %14.2f\n", "embree alone, photon tracer's rays", median(replay_rates),
              photon_rays_per_path);
  std::printf("%-34s %10.2f %14.2f\n", "  the same rays as streams of 64",
              median(replay_stream_rates), photon_rays_per_path);
  std::printf(
      "photon tracer / path tracer, cost per ray: %.2fx  (median of %zu alternating rounds; "
      "target <= 1.3x)\n",
      median(photon_cost_ratios), photon_cost_ratios.size());
  std::printf(
      "  of which Embree's queries (with our hit completion) on the photon tracer's own rays: "
      "%.2fx the path tracer's cost per ray (%.2fx as streams of 64); the photon tracer's code "
      "around them: %.2fx\n",
      median(ours) / median(replay_rates), median(ours) / median(replay_stream_rates),
      median(photon_cost_ratios) - median(ours) / median(replay_rates));
  std::printf("  Embree's share of the photon tracer's time: %.0f%%\n",
              100 * median(replay_shares));
  std::printf(
      "photon tracer with footprints / without, cost per ray: %.2fx  (the same photons; median "
      "of %zu alternating rounds)\n",
      median(footprint_cost_ratios), footprint_cost_ratios.size());
  if (theirs > 0)
    std::printf(
        "ratio (ours / embree): %.2fx  (median of %zu alternating rounds; target >= 1.0x)\n",
        median(ratios), ratios.size());
  return 0;
}
