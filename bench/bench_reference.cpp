// Renders each shipped scene's first metric frame of configs/quick.yaml at quick's resolution, to
// quick's error target, with the reference renderer's estimator (automatic: a pilot picks
// bidirectional or plain path tracing, reference.h) and with path tracing + NEE alone (the
// anchor), and prints the time ratio per scene: alternating rounds (the order flips every round),
// median ratio, of process CPU time (user + system, all threads: what the work costs, whatever
// else runs on the machine) and of wall time. Both stop by the same rule, the renderer's error
// estimate (reference.h) over the classes quick's cells score (combined, direct, indirect); a
// render that hits the time limit first is reported as such, and its ratio as a bound. Each error
// target of --rel-error (a comma-separated list) gets its own row per scene; the last line names
// the slowest row against path tracing. The header names the CPU and its vector units.
//
//   bench_reference [--scenes a,b,...] [--rounds N] [--rel-error E[,E...]] [--max-seconds S]
//                   [--resolution WxH] [--estimator auto|bdpt] [--threads N]
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "bench_support.h"
#include "cell/scoring.h"
#include "config/config.h"
#include "photonbench/error.h"
#include "reference/reference.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"

namespace fs = std::filesystem;
using namespace pb;

namespace {

struct Args {
  std::vector<std::string> scenes;
  int rounds = 3;
  std::vector<double> rel_errors;
  double max_seconds = -1;
  int width = 0, height = 0;
  trace::Estimator estimator = trace::Estimator::automatic;
  int threads = 0;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= s.size()) {
    size_t comma = s.find(',', start);
    if (comma == std::string::npos) comma = s.size();
    if (comma > start) out.push_back(s.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw InputError("bench_reference: " + k + " needs a value");
      return argv[++i];
    };
    if (k == "--scenes")
      a.scenes = split(value());
    else if (k == "--rounds")
      a.rounds = std::max(1, std::atoi(value().c_str()));
    else if (k == "--rel-error")
      for (const std::string& e : split(value())) a.rel_errors.push_back(std::atof(e.c_str()));
    else if (k == "--max-seconds")
      a.max_seconds = std::atof(value().c_str());
    else if (k == "--threads")
      a.threads = std::atoi(value().c_str());
    else if (k == "--resolution") {
      std::string v = value();
      if (std::sscanf(v.c_str(), "%dx%d", &a.width, &a.height) != 2)
        throw InputError("bench_reference: --resolution WIDTHxHEIGHT");
    } else if (k == "--estimator") {
      auto e = trace::parse_estimator(value());
      if (!e || *e == trace::Estimator::pt)
        throw InputError("bench_reference: --estimator auto or bdpt (pt is the anchor)");
      a.estimator = *e;
    } else {
      throw InputError("bench_reference: unknown option " + k);
    }
  }
  return a;
}

using pb::bench::median;

struct Run {
  double seconds = 0, cpu = 0, rel_error = 0;
  uint32_t iterations = 0;
  bool reached = false;
  trace::Estimator estimator = trace::Estimator::pt;
  trace::PilotReport pilot;
};

Run render(const trace::EmbreeScene& world, int w, int h, uint32_t mask,
           trace::ReferenceOptions o) {
  double cpu0 = pb::bench::process_cpu_seconds();
  trace::ReferenceResult r = trace::render_reference_classes(world, w, h, mask, o);
  return {r.seconds, pb::bench::process_cpu_seconds() - cpu0,    r.rel_error,
          r.samples, r.stopped_by == trace::StopRule::rel_error, r.estimator,
          r.pilot};
}

}  // namespace

int main(int argc, char** argv) {
  try {
    Args args = parse(argc, argv);
    fs::path root = PB_SOURCE_DIR;
    config::Config quick = config::load_config(root / "configs" / "quick.yaml", {});
    int w = args.width ? args.width : int(quick.width);
    int h = args.height ? args.height : int(quick.height);
    uint32_t frame = quick.frames.warmup;  // the first metric frame
    // The config's reference block alone, without any scene entry's own stop rules.
    trace::ReferenceOptions base = run::reference_options(quick, config::kNoSceneEntry);
    base.samples = 0;
    if (args.rel_errors.empty()) args.rel_errors.push_back(base.rel_error);
    if (args.max_seconds >= 0) base.max_seconds = args.max_seconds;
    base.threads = args.threads;
    for (double e : args.rel_errors)
      if (!(e > 0))
        throw InputError("bench_reference: needs an error target (quick.yaml's or --rel-error)");
    if (args.scenes.empty())
      for (const auto& e : fs::directory_iterator(root / "scenes"))
        if (e.path().extension() == ".yaml") args.scenes.push_back(e.path().stem().string());
    std::sort(args.scenes.begin(), args.scenes.end());
    uint32_t mask = trace::class_bit(trace::PathClass::combined) |
                    trace::class_bit(trace::PathClass::direct) |
                    trace::class_bit(trace::PathClass::indirect);
    std::string targets;
    for (double e : args.rel_errors)
      targets += fmt::format("{}{:.3f}", targets.empty() ? "" : ",", e);
    std::printf("bench_reference on %s\n",
                (pb::bench::cpu_model() + "; " + pb::bench::vector_units()).c_str());
    std::printf(
        "frame %u at %dx%d, classes combined+direct+indirect, stop at rel. error %s (limit %.0f s "
        "a "
        "render), %d round(s), %s vs pt\n",
        frame, w, h, targets.c_str(), base.max_seconds, args.rounds,
        std::string(trace::estimator_name(args.estimator)).c_str());
    std::printf("%-20s %6s %10s %10s %8s %8s %7s %7s  %s\n", "scene", "target", "pt cpu s",
                "new cpu s", "pt it", "new it", "ratio", "wall", "new estimator; pilot; notes");
    std::fflush(stdout);
    double slowest = std::numeric_limits<double>::infinity();
    std::string slowest_row;
    for (const std::string& name : args.scenes) {
      scene::Scene scene = scene::load_scene(scene::find_scene(name, {root / "scenes"}));
      trace::EmbreeScene world(scene, scene.at(frame), trace::one_frame_options());
      for (double target : args.rel_errors) {
        base.rel_error = float(target);
        std::vector<double> ratios, wall_ratios, pt_s, new_s, pt_it, new_it, pt_err, new_err,
            pilot_it, pilot_s, dropped;
        bool pt_capped = false, new_capped = false, same_capped = false;
        std::vector<std::string> chosen;  // the estimators the rounds chose, in order
        for (int round = 0; round < args.rounds; ++round) {
          trace::ReferenceOptions pt = base, fresh = base;
          pt.estimator = trace::Estimator::pt;
          fresh.estimator = args.estimator;
          pt.seed = fresh.seed = uint32_t(17 + round);
          Run a, b;
          if (round % 2 == 0) {
            a = render(world, w, h, mask, pt);
            b = render(world, w, h, mask, fresh);
          } else {
            b = render(world, w, h, mask, fresh);
            a = render(world, w, h, mask, pt);
          }
          pt_capped |= !a.reached;
          new_capped |= !b.reached;
          if (!a.reached && !b.reached && b.estimator == trace::Estimator::pt) {
            // Both stopped by the time limit, both path tracing with the same seeds: the same
            // image after the same iterations, so the time to any error is the time to its
            // iterations; time per iteration, with the pilot's cost spread over the iterations
            // done, fewer than the target needs (a lower bound).
            same_capped = true;
            ratios.push_back((a.cpu / a.iterations) / (b.cpu / b.iterations));
            wall_ratios.push_back((a.seconds / a.iterations) / (b.seconds / b.iterations));
          } else {
            // Both stopped by the time limit: the time each would need for the other's error,
            // from error^2 x time (path tracing's estimate only grows with more samples, so a
            // bound).
            double e2 = !a.reached && !b.reached
                            ? (a.rel_error * a.rel_error) / (b.rel_error * b.rel_error)
                            : 1.0;
            ratios.push_back(e2 * a.cpu / b.cpu);
            wall_ratios.push_back(e2 * a.seconds / b.seconds);
          }
          pt_err.push_back(a.rel_error), new_err.push_back(b.rel_error);
          pt_s.push_back(a.cpu), new_s.push_back(b.cpu);
          pt_it.push_back(a.iterations), new_it.push_back(b.iterations);
          pilot_it.push_back(b.pilot.iterations), pilot_s.push_back(b.pilot.seconds);
          dropped.push_back(b.pilot.dropped_iterations);
          std::string e(trace::estimator_name(b.estimator));
          if (std::find(chosen.begin(), chosen.end(), e) == chosen.end()) chosen.push_back(e);
        }
        std::string notes = fmt::format("{}", fmt::join(chosen, "/"));
        if (args.estimator == trace::Estimator::automatic)
          notes += fmt::format("; pilot {:.0f} it. {:.2f} s, {:.0f} pt it. dropped",
                               median(pilot_it), median(pilot_s), median(dropped));
        if (same_capped && chosen.size() > 1)
          notes += fmt::format(
              "; both hit the time limit (error {:.4f} vs {:.4f}): rounds of pt against pt by "
              "time per iteration, the others by error^2 x time",
              median(pt_err), median(new_err));
        else if (same_capped)
          notes += fmt::format(
              "; both pt, both hit the time limit (error {:.4f} vs {:.4f}): ratios of time per "
              "iteration, a lower bound",
              median(pt_err), median(new_err));
        else if (pt_capped && new_capped)
          notes += fmt::format(
              "; both hit the time limit (error {:.4f} vs {:.4f}): ratios of error^2 x time",
              median(pt_err), median(new_err));
        else if (pt_capped)
          notes +=
              fmt::format("; pt hit the time limit at error {:.4f}: the ratio is a lower bound",
                          median(pt_err));
        else if (new_capped)
          notes += "; new hit the time limit: the ratio is an upper bound";
        std::printf("%-20s %6.3f %10.1f %10.1f %8.0f %8.0f %6.2fx %6.2fx  %s\n", name.c_str(),
                    target, median(pt_s), median(new_s), median(pt_it), median(new_it),
                    median(ratios), median(wall_ratios), notes.c_str());
        std::fflush(stdout);
        if (median(ratios) < slowest)
          slowest = median(ratios), slowest_row = fmt::format("{} at {:.3f}", name, target);
      }
    }
    std::printf("slowest against pt (CPU time): %s, %.2fx\n", slowest_row.c_str(), slowest);
    return 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_reference: %s\n", e.what());
    return 1;
  }
}
