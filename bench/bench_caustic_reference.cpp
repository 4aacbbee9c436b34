// Photon mapping's time to a given error against the truth, before and after its speed-up: the
// caustic class of each scene's frame rendered by the reference renderer (estimator pt; with the
// caustics class alone nearly all the work is probabilistic progressive photon mapping,
// reference.h) with the old photon-mapping settings (uniform emission, 200000 photon paths an
// iteration, a radius of 3 pixel footprints) and with the new defaults of ReferenceOptions
// (--after-* overrides them for tuning). "Error" is measured against a long render of the same
// frame (the truth), with the truth's own variance taken off, so that photon mapping's blur bias,
// which its own estimate cannot see (README "Photon mapping's blur"), is counted: reference.h's
// relative error formula with a floor of the mean luminance instead of 1% of it (errors_against
// below says why; the 1% one is printed as well).
//
// Each side renders a ladder of iteration counts (4, 8, 16, ...; every render from iteration 0,
// the same seed, so each rung extends the previous one) until its error against the truth is at
// or below --target; its time to the target is interpolated on log(error) over log(time) between
// the last two rungs. Rounds alternate which side goes first; the ratio before / after (above 1:
// after is faster) is printed per round and as the median of the per-round ratios, of process CPU
// time (user + system, all threads) and of wall time. At the rung that reached the target it
// prints the renderer's own error estimate over the same formula's error against the truth (o/e;
// below 1: optimistic).
//
// The truth is rendered once per scene, frame, resolution and truth setting, with aimed emission
// (unbiased, README "Aimed emission"), and cached as EXR (mean and variance) under --truth-dir.
//
//   bench_caustic_reference [--scenes a,b] [--resolution WxH] [--frame F] [--target E]
//       [--rounds N] [--truth-iterations N] [--truth-photons N] [--truth-footprints R]
//       [--truth-dir DIR] [--truth-only 1]
//       [--after-photons N] [--after-footprints R] [--after-alpha A] [--after-aimed 0|1]
//       [--max-iterations N] [--max-cpu S] [--threads N] [--seed S]
// (--max-cpu: no further rung once one took this many CPU seconds; the side then reports a bound)
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "bench_support.h"
#include "io/image.h"
#include "photonbench/error.h"
#include "reference/path_space.h"
#include "reference/reference.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"

namespace fs = std::filesystem;
using namespace pb;

namespace {

constexpr const char* kUsage =
    "bench_caustic_reference [--scenes a,b] [--resolution WxH] [--frame F] [--target E] "
    "[--rounds N] [--truth-iterations N] [--truth-photons N] [--truth-footprints R] [--truth-dir "
    "DIR] [--truth-only 1] "
    "[--after-photons N] [--after-footprints R] [--after-alpha A] [--after-aimed 0|1] "
    "[--max-iterations N] [--max-cpu S] [--threads N] [--seed S]";

std::vector<std::string> comma_list(const std::string& text) {
  std::vector<std::string> names;
  std::stringstream in(text);
  for (std::string name; std::getline(in, name, ',');)
    if (!name.empty()) names.push_back(name);
  return names;
}

double luminance_of(const io::Image& img, size_t p) {
  return trace::detail::luminance(
      {img.pixels[p * 3], img.pixels[p * 3 + 1], img.pixels[p * 3 + 2]});
}

// Two errors of a render against the truth, both with the truth's variance (of its luminance, from
// the per-channel variance, channels taken as independent) taken off so that its noise is not
// charged to the render:
//   relative: reference.h's formula, sqrt(mean(((L - T)^2 - var T) / (T^2 + f^2))), f = 1% of the
//     truth's mean luminance: what the renderer's own estimate estimates, for the honesty check.
//     Where the truth is dark beside a caustic's edge, blur makes it huge (a blurred render's value
//     there over 1% of the mean);
//   relative to the mean: the same with f = the truth's mean luminance, the time-to-target
//     figure: relative where the caustic is bright, absolute (over the mean) where it is dark, so
//     neither the blur beside an edge nor the one pixel a focus lands on (in cornell-glass 1400
//     times the mean) decides it alone.
struct Errors {
  double relative = 0, to_mean = 0;
};

Errors errors_against(const io::Image& render, const io::Image& truth, const io::Image& variance) {
  size_t pixels = size_t(truth.width) * truth.height;
  double mean = 0;
  for (size_t p = 0; p < pixels; ++p) mean += luminance_of(truth, p) / double(pixels);
  double floor2 = std::pow(0.01 * mean, 2.0), relative = 0, to_mean = 0;
  const double w[3] = {0.2126, 0.7152, 0.0722};
  for (size_t p = 0; p < pixels; ++p) {
    double t = luminance_of(truth, p), d = luminance_of(render, p) - t, var_t = 0;
    for (int c = 0; c < 3; ++c) var_t += w[c] * w[c] * variance.pixels[p * 3 + c];
    relative += (d * d - var_t) / (t * t + floor2);
    to_mean += (d * d - var_t) / (t * t + mean * mean);
  }
  Errors e;
  e.relative = std::sqrt(std::max(0.0, relative / double(pixels)));
  e.to_mean = std::sqrt(std::max(0.0, to_mean / double(pixels)));
  return e;
}

struct Truth {
  io::Image mean, variance;
  double own_error = 0;
  uint32_t iterations = 0;
};

Truth load_or_render_truth(const scene::Scene& scene, const std::string& name, uint32_t frame,
                           int w, int h, uint32_t iterations, uint32_t photons, float footprints,
                           const fs::path& dir, int threads) {
  std::string stem = fmt::format("{}-f{}-{}x{}-caustics-v{}-it{}-ph{}-fp{}", name, frame, w, h,
                                 trace::kReferenceRendererVersion, iterations, photons, footprints);
  fs::path mean_file = dir / (stem + ".exr"), var_file = dir / (stem + ".variance.exr");
  Truth t;
  t.iterations = iterations;
  if (fs::exists(mean_file) && fs::exists(var_file)) {
    t.mean = io::read_image(mean_file);
    t.variance = io::read_image(var_file);
    std::printf("  truth %s: cached (%s)\n", name.c_str(), mean_file.c_str());
    return t;
  }
  trace::ReferenceOptions o;
  o.estimator = trace::Estimator::pt;
  o.samples = iterations;
  o.photon_mapping.photons = photons;
  o.photon_mapping.radius_footprints = footprints;
  o.photon_mapping.aimed_emission = true;
  o.seed = 0x7a07u;
  o.threads = threads;
  std::printf("  truth %s: rendering %u iterations of %u photon paths ...\n", name.c_str(),
              iterations, photons);
  std::fflush(stdout);
  trace::EmbreeScene world(scene, scene.at(frame));
  trace::ReferenceResult r =
      trace::render_reference_classes(world, w, h, trace::class_bit(trace::PathClass::caustics), o);
  const trace::ReferenceImage& img = r.classes[int(trace::PathClass::caustics)];
  t.mean = img.mean;
  t.variance = img.variance;
  t.own_error = r.rel_error;
  fs::create_directories(dir);
  io::write_image(var_file, t.variance);
  io::write_image(mean_file, t.mean);
  std::printf("  truth %s: %.0f s, its own error estimate %.4f (noise, taken off below)\n",
              name.c_str(), r.seconds, r.rel_error);
  return t;
}

struct Rung {
  uint32_t iterations = 0;
  double cpu = 0, wall = 0, error = 0, relative = 0, own_error = 0;  // error: relative to the mean
};

// Time to the target: the ladder until a rung's error against the truth reaches it, then
// log-log interpolation between the last two rungs (the first rung's time if it is already there).
struct ToTarget {
  bool reached = false, at_first_rung = false;
  double cpu = 0, wall = 0, iterations = 0;
  Rung last;
};

ToTarget time_to_target(const trace::EmbreeScene& world, int w, int h, const Truth& truth,
                        trace::ReferenceOptions o, double target, uint32_t max_iterations,
                        double max_cpu) {
  std::vector<Rung> rungs;
  for (uint32_t n = 4; n <= max_iterations; n *= 2) {
    o.samples = n;
    o.rel_error = 0;
    o.max_seconds = 0;
    double cpu0 = pb::bench::process_cpu_seconds();
    trace::ReferenceResult r = trace::render_reference_classes(
        world, w, h, trace::class_bit(trace::PathClass::caustics), o);
    Rung g;
    g.iterations = r.samples;
    g.cpu = pb::bench::process_cpu_seconds() - cpu0;
    g.wall = r.seconds;
    Errors e = errors_against(r.image(trace::PathClass::caustics), truth.mean, truth.variance);
    g.error = e.to_mean;
    g.relative = e.relative;
    g.own_error = r.rel_error;
    rungs.push_back(g);
    std::fprintf(stderr,
                 "    %s: %u iterations, %.2f s CPU, error %.4f, relative (1%% floor) %.4f (own "
                 "estimate %.4f)\n",
                 o.photon_mapping.aimed_emission ? "aimed" : "uniform", g.iterations, g.cpu,
                 g.error, g.relative, g.own_error);
    if (g.error <= target || g.cpu > max_cpu) break;
  }
  ToTarget out;
  out.last = rungs.back();
  out.reached = out.last.error <= target;
  out.at_first_rung = out.reached && rungs.size() == 1;
  if (!out.reached || rungs.size() == 1) {
    out.cpu = out.last.cpu, out.wall = out.last.wall, out.iterations = out.last.iterations;
    return out;
  }
  const Rung& a = rungs[rungs.size() - 2];
  const Rung& b = rungs.back();
  double f = (std::log(a.error) - std::log(target)) / (std::log(a.error) - std::log(b.error));
  auto between = [&](double x, double y) {
    return std::exp(std::log(x) + f * (std::log(y) - std::log(x)));
  };
  out.cpu = between(a.cpu, b.cpu);
  out.wall = between(a.wall, b.wall);
  out.iterations = between(a.iterations, b.iterations);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    auto opt = bench::parse_options(argc, argv,
                                    {{"--scenes", "cornell-glass,torus-in-glass-cube"},
                                     {"--resolution", "160x90"},
                                     {"--frame", "4"},
                                     {"--target", "0.2"},
                                     {"--rounds", "3"},
                                     {"--truth-iterations", "256"},
                                     {"--truth-photons", "1000000"},
                                     {"--truth-footprints", "1"},
                                     {"--truth-only", "0"},
                                     {"--truth-dir", "results/caustic-truth"},
                                     {"--after-photons", ""},
                                     {"--after-footprints", ""},
                                     {"--after-alpha", ""},
                                     {"--after-aimed", ""},
                                     {"--max-iterations", "4096"},
                                     {"--max-cpu", "300"},
                                     {"--threads", "0"},
                                     {"--seed", "17"}},
                                    kUsage);
    if (!opt) return 2;
    auto& a = *opt;
    int w = 0, h = 0;
    if (std::sscanf(a["--resolution"].c_str(), "%dx%d", &w, &h) != 2 || w <= 0 || h <= 0)
      throw InputError("bench_caustic_reference: --resolution WIDTHxHEIGHT");
    uint32_t frame = uint32_t(std::stoul(a["--frame"]));
    double target = std::stod(a["--target"]);
    int rounds = std::max(1, std::stoi(a["--rounds"]));
    int threads = std::stoi(a["--threads"]);
    uint32_t max_iterations = uint32_t(std::stoul(a["--max-iterations"]));
    uint32_t seed = uint32_t(std::stoul(a["--seed"]));
    double max_cpu = std::stod(a["--max-cpu"]);

    trace::ReferenceOptions before;  // the settings before the speed-up
    before.estimator = trace::Estimator::pt;
    before.photon_mapping.photons = 200000;
    before.photon_mapping.alpha = 2.f / 3.f;
    before.photon_mapping.radius_footprints = 3.f;
    before.photon_mapping.aimed_emission = false;
    before.threads = threads;
    trace::ReferenceOptions after;  // the defaults now
    after.estimator = trace::Estimator::pt;
    after.threads = threads;
    if (!a["--after-photons"].empty())
      after.photon_mapping.photons = uint32_t(std::stoul(a["--after-photons"]));
    if (!a["--after-footprints"].empty())
      after.photon_mapping.radius_footprints = std::stof(a["--after-footprints"]);
    if (!a["--after-alpha"].empty()) after.photon_mapping.alpha = std::stof(a["--after-alpha"]);
    if (!a["--after-aimed"].empty())
      after.photon_mapping.aimed_emission = a["--after-aimed"] != "0";
    auto describe = [](const trace::ReferenceOptions& o) {
      return fmt::format("{} photon paths, radius {} footprints, alpha {:.3f}, {} emission",
                         o.photon_mapping.photons, o.photon_mapping.radius_footprints,
                         o.photon_mapping.alpha,
                         o.photon_mapping.aimed_emission ? "aimed" : "uniform");
    };
    std::printf(
        "bench_caustic_reference: vector units: %s; class caustics, frame %u at %dx%d, time to "
        "error %.3f against the truth, %d round(s), ratio before / after (CPU and wall)\n",
        pb::bench::vector_units().c_str(), frame, w, h, target, rounds);
    std::printf("  before: %s\n  after:  %s\n", describe(before).c_str(), describe(after).c_str());
    std::fflush(stdout);

    fs::path root = bench::source_dir();
    for (const std::string& name : comma_list(a["--scenes"])) {
      scene::Scene scene = scene::load_scene(scene::find_scene(name, {root / "scenes"}));
      Truth truth = load_or_render_truth(
          scene, name, frame, w, h, uint32_t(std::stoul(a["--truth-iterations"])),
          uint32_t(std::stoul(a["--truth-photons"])), std::stof(a["--truth-footprints"]),
          a["--truth-dir"], threads);
      if (a["--truth-only"] == "1") continue;
      trace::EmbreeScene world(scene, scene.at(frame));
      std::printf("%-20s %5s %8s %8s %7s %7s %7s %7s %7s %7s %8s %8s\n", name.c_str(), "round",
                  "bef cpu", "aft cpu", "bef it", "aft it", "bef e", "aft e", "bef o/e", "aft o/e",
                  "cpu x", "wall x");
      std::vector<double> cpu_ratios, wall_ratios;
      bool bound = false;
      for (int round = 0; round < rounds; ++round) {
        ToTarget results[2];
        for (int k = 0; k < 2; ++k) {
          int side = (round % 2 == 0) ? k : 1 - k;  // alternate which side goes first
          trace::ReferenceOptions o = side == 0 ? before : after;
          o.seed = seed + uint32_t(round);
          results[side] = time_to_target(world, w, h, truth, o, target, max_iterations, max_cpu);
        }
        const ToTarget &b = results[0], &f = results[1];
        bound = bound || !b.reached || !f.reached || f.at_first_rung;
        cpu_ratios.push_back(b.cpu / f.cpu);
        wall_ratios.push_back(b.wall / f.wall);
        std::printf("%-20s %5d %8.2f %8.2f %7.0f %7.0f %7.4f %7.4f %7.2f %7.2f %7.2fx %7.2fx%s\n",
                    "", round, b.cpu, f.cpu, b.iterations, f.iterations, b.last.error, f.last.error,
                    b.last.own_error / b.last.relative, f.last.own_error / f.last.relative,
                    cpu_ratios.back(), wall_ratios.back(),
                    !b.reached || !f.reached ? "  (a side stopped short: a bound)"
                    : f.at_first_rung        ? "  (after at its first rung: a lower bound)"
                                             : "");
        std::fflush(stdout);
      }
      std::printf("%-20s median before / after: CPU %.2fx, wall %.2fx%s\n", name.c_str(),
                  bench::median(cpu_ratios), bench::median(wall_ratios), bound ? " (a bound)" : "");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_caustic_reference: %s\n", e.what());
    return 1;
  }
}
