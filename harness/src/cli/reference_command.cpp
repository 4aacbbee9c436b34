// `photonbench reference SCENE`: renders reference images of a scene's frames into the
// content-addressed cache (resumable: what is cached is skipped), with progress. The loop itself is
// pb::trace::render_references, which the runner calls for the frames a config scores.
#include <fmt/format.h>

#include <bit>
#include <cstdio>
#include <string>
#include <vector>

#include "cli/command.h"
#include "config/config.h"
#include "config/reference_rules.h"
#include "photonbench/error.h"
#include "plan/plugins.h"
#include "reference/reference.h"
#include "run/runner.h"
#include "scene/scene.h"

namespace {

// Stop-rule defaults are the config's (config::ReferenceSettings), so `reference SCENE` renders
// what a run would.
struct Args {
  std::string scene;
  std::string frames;
  std::vector<std::string> classes;
  double rel_error = pb::config::ReferenceSettings{}.rel_error;
  double max_seconds = pb::config::ReferenceSettings{}.max_seconds;
  uint32_t samples = pb::config::ReferenceSettings{}.samples;
  uint32_t max_bounces = 0;
  std::string estimator = pb::config::ReferenceSettings{}.estimator;
  std::string light_sampler = pb::config::ReferenceSettings{}.light_sampler;
  uint32_t photons = pb::trace::PhotonMappingOptions{}.photons;
  std::string resolution = "640x360";
  std::string cache = "results/reference-cache";
  uint32_t seed = 1;
  int threads = 0;
};

// "a:b" (inclusive), "a" or "" (the scene's default animation). Frame numbers are plain decimal
// integers below config::kMaxFrames: "-1" is an error, not frame 4294967295.
std::pair<uint32_t, uint32_t> parse_frames(const std::string& text, uint32_t default_frames) {
  if (text.empty()) return {0, default_frames > 0 ? default_frames - 1 : 0};
  auto bad = [&] {
    return pb::InputError(fmt::format("--frames: '{}' is not FIRST:LAST or FRAME (frames 0 to {})",
                                      pb::config::quote(text), pb::config::kMaxFrames - 1));
  };
  auto frame = [&](const std::string& part) {
    if (part.empty() || part.size() > 8 ||
        part.find_first_not_of("0123456789") != std::string::npos ||
        std::stoul(part) >= pb::config::kMaxFrames)
      throw bad();
    return uint32_t(std::stoul(part));
  };
  size_t colon = text.find(':');
  if (colon == std::string::npos) return {frame(text), frame(text)};
  uint32_t a = frame(text.substr(0, colon)), b = frame(text.substr(colon + 1));
  if (b < a) throw bad();
  return {a, b};
}

std::pair<int, int> parse_resolution(const std::string& text) {
  int w = 0, h = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &w, &x, &h) != 3 || (x != 'x' && x != 'X') || w <= 0 ||
      h <= 0 || w > 16384 || h > 16384)
    throw pb::InputError(fmt::format("--resolution: '{}' is not WIDTHxHEIGHT", text));
  return {w, h};
}

void add_reference(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "reference",
      "render reference images (mean, variance, halves) of a scene's frames into the cache");
  cmd->add_option(
         "scene", args->scene,
         "scene name (under scenes/), path to a scene file, or a benchmark config: then every "
         "reference its cells will be scored against is rendered (what `run` would render)")
      ->required();
  cmd->add_option("--frames", args->frames, "FIRST:LAST or FRAME (default: the scene's animation)");
  std::string class_help = "path class, repeatable: ";
  for (auto c : pb::trace::all_path_classes())
    class_help += fmt::format("{} ({}); ", pb::trace::path_class_name(c),
                              pb::trace::path_class_expression(c));
  cmd->add_option("--class", args->classes, class_help + "default combined");
  cmd->add_option("--rel-error", args->rel_error,
                  "stop rule: estimated relative RMS error of the mean (0: off)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--max-seconds", args->max_seconds, "stop rule: seconds per frame (0: off)")
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--samples", args->samples, "stop rule: iterations, 0 (off) or at least 2")
      ->check(CLI::Range(0u, 1u << 24));
  cmd->add_option("--max-bounces", args->max_bounces,
                  "scattering vertices on a full path between camera and light (0: untruncated)")
      ->check(CLI::Range(0u, pb::trace::kUntruncatedBounces));
  cmd->add_option(
         "--estimator", args->estimator,
         "auto (a pilot picks the cheaper of the two per frame, the default), bdpt "
         "(bidirectional path tracing) or pt (path tracing with next-event estimation, the "
         "anchor); photon mapping adds the caustic-type paths to each")
      ->check(CLI::IsMember(pb::config::estimator_names()));
  cmd->add_option("--light-sampler", args->light_sampler,
                  "path tracing's next-event light choice: power (by power alone, the default) "
                  "or bvh (the light BVH's walk from the shading point: fewer samples to an "
                  "error, slower per sample)")
      ->check(CLI::IsMember(pb::config::light_sampler_names()));
  cmd->add_option("--photons", args->photons, "photon paths per photon-mapping iteration")
      ->check(CLI::Range(1u, 1u << 26));
  cmd->add_option("--resolution", args->resolution, "WIDTHxHEIGHT");
  cmd->add_option("--cache", args->cache, "cache directory");
  cmd->add_option("--seed", args->seed, "random seed");
  cmd->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(CLI::Range(0, 4096));
  cmd->callback([args, &exit_code] {
    if (pb::run::is_benchmark_config(args->scene)) {
      auto config = pb::config::load_config(args->scene, {});
      pb::run::PluginRegistry plugins(config.plugin_dirs);
      pb::run::render_needed_references(config, pb::run::expand_cells(config, plugins), plugins);
      exit_code = 0;
      return;
    }
    auto file = pb::scene::find_scene(args->scene, {});
    pb::scene::Scene scene = pb::scene::load_scene(file);
    auto [first, last] = parse_frames(args->frames, scene.default_frames);
    pb::scene::check_frames(scene, first, last);  // before any frame renders
    auto [width, height] = parse_resolution(args->resolution);
    uint32_t mask = 0;
    if (args->classes.empty()) args->classes.push_back("combined");
    for (const auto& name : args->classes) {
      auto c = pb::trace::parse_path_class(name);
      if (!c) throw pb::InputError(fmt::format("--class: unknown path class '{}'", name));
      mask |= pb::trace::class_bit(*c);
    }
    pb::trace::ReferenceOptions options;
    options.rel_error = float(args->rel_error);
    options.max_seconds = args->max_seconds;
    options.samples = args->samples;
    options.max_bounces = args->max_bounces;
    options.estimator = *pb::trace::parse_estimator(args->estimator);
    options.light_selection = *pb::trace::parse_light_selection(args->light_sampler);
    options.photon_mapping.photons = args->photons;
    options.seed = args->seed;
    options.threads = args->threads;
    options.validate();  // before any frame renders
    pb::trace::ReferenceCache cache(args->cache);
    std::printf(
        "reference: %s frames %u..%u, %dx%d, %d class(es), stop at rel. error %g / %g s / %u "
        "samples (0: off), cache %s\n",
        scene.name.c_str(), first, last, width, height, std::popcount(mask), args->rel_error,
        args->max_seconds, args->samples, args->cache.c_str());
    std::fflush(stdout);
    auto report = pb::trace::render_references(scene, first, last, mask, width, height, options,
                                               cache, [](const std::string& line) {
                                                 std::printf("%s\n", line.c_str());
                                                 std::fflush(stdout);
                                               });
    std::printf("reference: %d rendered, %d cached, %.1f s\n", report.rendered, report.cached,
                report.seconds);
    exit_code = 0;
  });
}

pb::cli::CommandRegistration reference_registration{"reference", add_reference};

}  // namespace
