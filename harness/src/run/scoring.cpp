#include "run/scoring.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "io/image.h"
#include "io/results.h"
#include "metrics/metrics.h"
#include "trace/reference.h"

namespace pb::run {

using json = nlohmann::json;

std::optional<trace::PathClass> reference_class_of(const std::string& path_class) {
  // A technique names its class by the reference's name ("caustics") or its light path expression.
  auto squeeze = [](std::string s) {
    s.erase(std::remove(s.begin(), s.end(), ' '), s.end());
    return s;
  };
  if (auto by_name = trace::parse_path_class(path_class)) return by_name;
  for (trace::PathClass c : trace::all_path_classes())
    if (squeeze(std::string(trace::path_class_expression(c))) == squeeze(path_class)) return c;
  return std::nullopt;
}

trace::ReferenceOptions reference_options(const config::Config& config) {
  trace::ReferenceOptions options;
  options.rel_error = float(config.reference.rel_error);
  options.max_seconds = config.reference.max_seconds;
  options.samples = config.reference.samples;
  options.max_bounces = config.reference.max_bounces;
  options.estimator =
      trace::parse_estimator(config.reference.estimator).value_or(trace::Estimator::automatic);
  options.seed = uint32_t(config.seed);
  return options;
}

uint32_t reference_classes(const std::string& technique_path_class) {
  uint32_t mask = trace::class_bit(trace::PathClass::combined);
  if (auto c = reference_class_of(technique_path_class)) mask |= trace::class_bit(*c);
  return mask;
}

std::string class_image_name(uint32_t frame, trace::PathClass path_class) {
  return fmt::format("frame_{:04d}_{}.exr", frame, trace::path_class_name(path_class));
}

std::vector<uint32_t> metric_frames(const config::Config& config) {
  std::vector<uint32_t> frames;
  if (config.frames.metrics_every == 0) return frames;
  for (uint32_t i = 0; i < config.frames.count; i += config.frames.metrics_every)
    frames.push_back(config.frames.warmup + i);
  return frames;
}

ScoreResult score_cell(const config::Config& config, const config::Cell&, const scene::Scene& scene,
                       const std::vector<uint32_t>& frames, const std::string& path_class,
                       const std::filesystem::path& cell_dir) {
  ScoreResult result;
  io::CsvAppender metrics_csv(cell_dir / "metrics.csv",
                              {"frame", "path_class", "flip", "ssim", "psnr", "rmse", "relmse"});
  if (frames.empty()) return result;

  // The technique's output is scored against the combined reference always, and against the reference
  // of its own class: by the output itself when that class is the whole of it (direct: emitted plus
  // direct light), else by the estimate it handed to shade(), which the cell runner wrote alone
  // (class_image_name) before the shared direct light was added to it.
  std::vector<trace::PathClass> classes = {trace::PathClass::combined};
  auto own = reference_class_of(path_class);
  if (!own) result.warnings.push_back(fmt::format("path class '{}' has no reference image; scored as combined", path_class));
  else if (*own != trace::PathClass::combined) classes.push_back(*own);

  trace::ReferenceCache cache(config.reference.cache_dir);
  trace::ReferenceOptions options = reference_options(config);
  std::map<trace::PathClass, std::vector<double>> flip, ssim, psnr, rmse, relmse;
  for (uint32_t f : frames) {
    const io::Image output = io::read_image(cell_dir / "images" / fmt::format("frame_{:04d}.exr", f));
    scene::FrameState state = scene.at(f);
    for (trace::PathClass c : classes) {
      std::string name(trace::path_class_name(c));
      bool alone = c != trace::PathClass::combined && c != trace::PathClass::direct;
      std::filesystem::path alone_file = cell_dir / "images" / class_image_name(f, c);
      if (alone && !std::filesystem::exists(alone_file)) {
        result.warnings.push_back(fmt::format(
            "frame {}: the technique handed no indirect estimate to shade(); class '{}' not scored", f, name));
        continue;
      }
      const io::Image test = alone ? io::read_image(alone_file) : output;
      io::Image reference = cache.get_or_render(scene, state, c, test.width, test.height, options);
      io::Image error_map;
      metrics::Scores s = metrics::evaluate(reference, test, {}, &error_map);
      metrics_csv.row({std::to_string(f), name, fmt::format("{:.6f}", s.flip.mean), fmt::format("{:.6f}", s.ssim),
                       s.psnr ? fmt::format("{:.4f}", *s.psnr) : "", fmt::format("{:.6g}", s.rmse),
                       fmt::format("{:.6g}", s.relmse)});
      io::write_image(cell_dir / "images" / fmt::format("flip_{:04d}_{}.png", f, name), metrics::magma(error_map));
      io::write_image(cell_dir / "images" / fmt::format("reference_{:04d}_{}.png", f, name),
                      io::display_encode(reference));
      flip[c].push_back(s.flip.mean);
      ssim[c].push_back(s.ssim);
      if (s.psnr) psnr[c].push_back(*s.psnr);
      rmse[c].push_back(s.rmse);
      relmse[c].push_back(s.relmse);
    }
  }
  auto mean = [](const std::vector<double>& v) -> json {
    if (v.empty()) return nullptr;
    double sum = 0;
    for (double x : v) sum += x;
    return sum / double(v.size());
  };
  for (trace::PathClass c : classes)
    result.means[std::string(trace::path_class_name(c))] = {
        {"flip", mean(flip[c])}, {"ssim", mean(ssim[c])}, {"psnr", mean(psnr[c])},
        {"rmse", mean(rmse[c])}, {"relmse", mean(relmse[c])}, {"frames", flip[c].size()}};
  return result;
}

}  // namespace pb::run
