// photonbench metrics: scores one test image against a reference with every metric, on its own
// (no config, no run). PNG inputs are LDR (8-bit sRGB), EXR inputs HDR (linear); FLIP runs as
// LDR-FLIP or HDR-FLIP accordingly.
//
//   photonbench metrics --reference R --test T [--json] [--error-map OUT.png] [--ppd N]
//                       [--tonemapper aces|hable|reinhard]
#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli/command.h"
#include "io/image.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace {

struct MetricsArgs {
  std::string reference, test, error_map, tonemapper = "aces";
  double ppd = pb::metrics::kDefaultPixelsPerDegree;
  bool json = false;
};

// Keys in the order the issue documents them (ordered_json keeps insertion order).
nlohmann::ordered_json to_json(const pb::metrics::Scores& s) {
  nlohmann::ordered_json j;
  j["flip"] = {{"mean", s.flip.mean}, {"weighted_median", s.flip.weighted_median},
               {"q1", s.flip.q1},     {"q3", s.flip.q3},
               {"min", s.flip.min},   {"max", s.flip.max}};
  j["ssim"] = s.ssim;
  j["psnr"] = s.psnr ? nlohmann::ordered_json(*s.psnr) : nlohmann::ordered_json(nullptr);
  j["identical"] = s.identical;
  j["rmse"] = s.rmse;
  j["mae"] = s.mae;
  j["relmse"] = s.relmse;
  return j;
}

void print_table(const MetricsArgs& a, const pb::io::Image& reference,
                 const pb::metrics::Scores& s) {
  std::printf("reference  %s\ntest       %s\n", a.reference.c_str(), a.test.c_str());
  std::printf("%s-FLIP, %.2f pixels per degree%s\n", reference.linear ? "HDR" : "LDR", a.ppd,
              reference.linear ? fmt::format(", {} tone mapper", a.tonemapper).c_str() : "");
  std::printf("  FLIP mean             %.6f\n", s.flip.mean);
  std::printf("  FLIP weighted median  %.6f   (quartiles %.6f, %.6f)\n", s.flip.weighted_median,
              s.flip.q1, s.flip.q3);
  std::printf("  FLIP min / max        %.6f / %.6f\n", s.flip.min, s.flip.max);
  std::printf("  SSIM                  %.6f\n", s.ssim);
  if (s.psnr)
    std::printf("  PSNR                  %.4f dB\n", *s.psnr);
  else
    std::printf("  PSNR                  identical images\n");
  std::printf("  RMSE / MAE (linear)   %.6g / %.6g\n", s.rmse, s.mae);
  std::printf("  relMSE                %.6g\n", s.relmse);
}

void run(const MetricsArgs& a) {
  pb::metrics::FlipOptions options;
  options.pixels_per_degree = a.ppd;
  options.tonemapper = pb::metrics::parse_tonemapper(a.tonemapper);
  const pb::io::Image reference = pb::io::read_image(a.reference);
  const pb::io::Image test = pb::io::read_image(a.test);
  pb::io::Image error_map;
  pb::metrics::Scores scores;
  try {
    scores =
        pb::metrics::evaluate(reference, test, options, a.error_map.empty() ? nullptr : &error_map);
  } catch (const pb::InputError& e) {
    // The metrics do not know the file names; the user needs them.
    throw pb::InputError(fmt::format("{} vs {}: {}", a.reference, a.test, e.what()));
  }
  if (!a.error_map.empty()) {
    // PNG: the magma-mapped map the FLIP papers show; EXR: the raw error values.
    const bool exr =
        a.error_map.size() >= 4 && a.error_map.substr(a.error_map.size() - 4) == ".exr";
    pb::io::write_image(a.error_map, exr ? error_map : pb::metrics::magma(error_map));
  }
  if (a.json)
    std::printf("%s\n", to_json(scores).dump(2).c_str());
  else
    print_table(a, reference, scores);
}

void add_metrics(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<MetricsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "metrics", "Score a test image against a reference: FLIP, SSIM, PSNR, RMSE, MAE, relMSE");
  cmd->add_option("-r,--reference", args->reference, "reference image (PNG: LDR, EXR: HDR)")
      ->required();
  cmd->add_option("-t,--test", args->test, "test image, same size and kind as the reference")
      ->required();
  cmd->add_flag("--json", args->json, "print one JSON object instead of a table");
  cmd->add_option("--error-map", args->error_map,
                  "write FLIP's error map: .png in the magma colour map, .exr as raw values");
  cmd->add_option("--ppd", args->ppd, "FLIP's pixels per degree (default 67.02, the FLIP tool's)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--tonemapper", args->tonemapper, "HDR-FLIP tone mapper")
      ->check(CLI::IsMember({"aces", "hable", "reinhard"}, CLI::ignore_case));
  cmd->callback([args, &exit_code] {
    run(*args);
    exit_code = 0;
  });
}

pb::cli::CommandRegistration metrics_registration{"metrics", add_metrics};

}  // namespace
