#include "cell/scoring.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "io/image.h"
#include "io/results.h"
#include "metrics/flicker.h"
#include "metrics/metrics.h"
#include "metrics/noise_floor.h"
#include "reference/reference.h"

namespace pb::run {

using json = nlohmann::json;

trace::ReferenceOptions reference_options(const config::Config& config, size_t scene_entry) {
  const config::ReferenceSettings settings = config::reference_settings(config, scene_entry);
  trace::ReferenceOptions options;
  options.rel_error = float(settings.rel_error);
  options.max_seconds = settings.max_seconds;
  options.samples = settings.samples;
  options.max_bounces = settings.max_bounces;
  options.estimator =
      trace::parse_estimator(settings.estimator).value_or(trace::Estimator::automatic);
  options.light_selection =
      trace::parse_light_selection(settings.light_sampler).value_or(trace::LightSelection::power);
  options.seed = uint32_t(config.seed);
  return options;
}

uint32_t reference_classes(const std::string& technique_path_class) {
  uint32_t mask = trace::class_bit(trace::PathClass::combined);
  if (auto c = trace::reference_class_of(technique_path_class)) mask |= trace::class_bit(*c);
  return mask;
}

std::string class_image_name(uint32_t frame, trace::PathClass path_class) {
  return fmt::format("frame_{:04d}_{}.exr", frame, trace::path_class_name(path_class));
}

std::vector<uint32_t> metric_frames(const config::Config& config) {
  const config::FrameSettings& f = config.frames;
  std::vector<uint32_t> frames;
  if (f.metrics_every == 0) return frames;
  // Windows that overlap (metrics_window > metrics_every) score each frame once.
  for (uint32_t start = 0; start < f.count; start += f.metrics_every)
    for (uint32_t i = start; i < std::min(f.count, start + f.metrics_window); ++i)
      if (frames.empty() || frames.back() < f.start + i) frames.push_back(f.start + i);
  return frames;
}

std::vector<ScoredReference> scored_references(const config::Config& config, const Cell& cell) {
  std::vector<ScoredReference> out = {{"full", reference_options(config, cell.scene_entry)}};
  auto bounces = cell.params.find("max_bounces");
  if (config.reference.bounce_matched && bounces != cell.params.end()) {
    ScoredReference matched{"bounce_matched", reference_options(config, cell.scene_entry)};
    matched.options.max_bounces =
        trace::bounces_matching_photon_technique(uint32_t(std::stoul(bounces->second)));
    out.push_back(matched);
  }
  return out;
}

namespace {

// metrics.csv's columns after frame, path_class and reference: each score the config's `metrics`
// names, in this order, then their noise floors (metrics/noise_floor.h: what the true image
// scores against this reference), then the squared errors with the reference's noise taken off
// (rmse's mse_unbiased, relmse's relmse_unbiased), then the flicker since the frame before and
// its floor (metrics/flicker.h; empty unless that frame was scored too: frames.metrics_window).
const std::vector<std::string> kScoreColumns = {"flip", "ssim", "psnr", "rmse", "relmse", "mae"};

// The columns beyond a metric and its floor that it brings: to metrics.csv, and to cell.json's
// means only.
std::vector<std::string> unbiased_columns(const std::string& metric) {
  if (metric == "rmse") return {"mse_unbiased"};
  if (metric == "relmse") return {"relmse_unbiased"};
  return {};
}
std::vector<std::string> mean_only_columns(const std::string& metric) {
  if (metric == "rmse") return {"mse_floor", "mse_floor_halves"};
  return {};
}

bool named(const std::vector<std::string>& metrics, const std::string& metric) {
  return std::find(metrics.begin(), metrics.end(), metric) != metrics.end();
}

// One row's values by column name; PSNR is absent when the images are identical.
using Row = std::map<std::string, std::optional<double>>;

metrics::NoisyReference noisy_reference(const trace::ReferenceImage& reference) {
  return {reference.mean, reference.variance, reference.half[0], reference.half[1]};
}

// The previous metric frame of one class and reference: what the next frame's flicker compares
// when it is the frame just before (flicker compares consecutive frames only: over a gap of frames,
// a technique that reuses work across frames would be compared with one that does not after the
// reuse has been given up).
struct ScoredFrame {
  uint32_t frame;
  io::Image test;
  trace::ReferenceImage reference;
};

// FLIP and its floor only when the config names FLIP: they are three FLIP evaluations a row, which
// were 29% and 54% of two techniques' tests under the sanitizers (perf samples of
// Cluster.EveryVariantGivesTiledsImageOnCornellBox and RsmPhotons.GatheringAgreesWithSplatting,
// both `metrics: [psnr]`), for columns that written_columns then dropped.
Row score_row(const trace::ReferenceImage& reference, const io::Image& test, io::Image* error_map,
              const ScoredFrame* previous, const metrics::MetricSelection& selection) {
  const metrics::NoisyReference noisy = noisy_reference(reference);
  const metrics::Scores s = metrics::evaluate(reference.mean, test, {}, error_map, selection);
  const metrics::NoiseFloor f = metrics::noise_floor(noisy, {}, selection);
  const metrics::UnbiasedErrors u = metrics::unbiased_errors(noisy, test);
  std::optional<metrics::Flicker> flicker;
  // Flicker is relative to the references' level: where both are black (a class with no light in
  // the view, such as a caustic class of a frame whose caustic is off screen) it has no value, and
  // is left empty rather than failing the cell.
  auto lit = [](const trace::ReferenceImage& r) {  // any colour channel above zero
    const io::Image& m = r.mean;
    for (size_t i = 0; i < m.pixels.size(); ++i)
      if (i % size_t(m.channels) < 3 && m.pixels[i] > 0) return true;
    return false;
  };
  if (previous && (lit(previous->reference) || lit(reference)))
    flicker = metrics::flicker(noisy_reference(previous->reference), noisy, previous->test, test);
  return {{"flip", s.flip.mean},
          {"ssim", s.ssim},
          {"psnr", s.psnr},
          {"rmse", s.rmse},
          {"relmse", s.relmse},
          {"mae", s.mae},
          {"flip_floor", f.scores.flip.mean},
          {"ssim_floor", f.scores.ssim},
          {"psnr_floor", f.scores.psnr},
          {"rmse_floor", f.scores.rmse},
          {"relmse_floor", f.scores.relmse},
          {"mae_floor", f.scores.mae},
          {"mse_unbiased", u.mse},
          {"relmse_unbiased", u.relmse},
          {"mse_floor", f.mse},
          {"mse_floor_halves", f.mse_from_halves},
          {"flicker", flicker ? std::optional(flicker->value) : std::nullopt},
          {"flicker_floor", flicker ? std::optional(flicker->floor) : std::nullopt}};
}

std::vector<std::string> csv_header(const std::vector<std::string>& metrics) {
  std::vector<std::string> header = {"frame", "path_class", "reference"};
  for (const auto& c : kScoreColumns)
    if (named(metrics, c)) header.push_back(c);
  for (const auto& c : kScoreColumns)
    if (named(metrics, c)) header.push_back(c + "_floor");
  for (const auto& c : kScoreColumns)
    if (named(metrics, c))
      for (const auto& u : unbiased_columns(c)) header.push_back(u);
  header.push_back("flicker");
  header.push_back("flicker_floor");
  return header;
}

// A row with only the columns the config's metrics write (to metrics.csv and cell.json's means).
Row written_columns(const Row& row, const std::vector<std::string>& metrics) {
  std::vector<std::string> columns = csv_header(metrics);
  for (const auto& c : kScoreColumns)
    if (named(metrics, c))
      for (const auto& m : mean_only_columns(c)) columns.push_back(m);
  Row out;
  for (const auto& c : columns)
    if (auto it = row.find(c); it != row.end()) out[c] = it->second;
  return out;
}

std::string csv_value(const std::string& column, const std::optional<double>& v) {
  if (!v) return "";
  return column == "psnr" || column == "psnr_floor" ? fmt::format("{:.4f}", *v)
                                                    : fmt::format("{:.6g}", *v);
}

// Per-class means over the frames of every column of the rows (a column missing from a row, as an
// identical pair's PSNR, is left out of its mean).
json class_means(const std::vector<Row>& rows, const std::vector<std::string>& metrics) {
  std::map<std::string, std::pair<double, int>> sums;
  for (const Row& r : rows)
    for (const auto& [k, v] : r)
      if (v) sums[k].first += *v, sums[k].second += 1;
  json out = json::object();
  for (const auto& c : csv_header(metrics)) out[c] = nullptr;
  out.erase("frame"), out.erase("path_class"), out.erase("reference");
  for (const auto& [k, s] : sums) out[k] = s.first / s.second;
  out["frames"] = rows.size();
  return out;
}

// The classes a cell is scored in: the combined reference always, and the reference of the
// technique's own class: by the output itself when that class is the whole of it (direct: emitted
// plus direct light), else by the estimate it handed to shade(), which the cell runner wrote alone
// (class_image_name) before the shared direct light was added to it; then each class the technique
// handed back an image of (Context::class_output), by that image.
std::vector<trace::PathClass> scored_classes(const std::string& path_class,
                                             const std::vector<trace::PathClass>& class_outputs,
                                             std::vector<std::string>& warnings) {
  std::vector<trace::PathClass> classes = {trace::PathClass::combined};
  auto own = trace::reference_class_of(path_class);
  if (!own)
    warnings.push_back(
        fmt::format("path class '{}' has no reference image; scored as combined", path_class));
  else if (*own != trace::PathClass::combined)
    classes.push_back(*own);
  for (trace::PathClass c : class_outputs)
    if (std::find(classes.begin(), classes.end(), c) == classes.end()) classes.push_back(c);
  return classes;
}

// The full reference of one frame and class as the report shows it, with its FLIP error map when
// FLIP is scored (error_map non-null).
void write_report_images(const std::filesystem::path& cell_dir, uint32_t frame,
                         const std::string& class_name, const trace::ReferenceImage& reference,
                         const io::Image* error_map) {
  if (error_map)
    io::write_image(cell_dir / "images" / fmt::format("flip_{:04d}_{}.png", frame, class_name),
                    metrics::magma(*error_map));
  io::write_image(cell_dir / "images" / fmt::format("reference_{:04d}_{}.png", frame, class_name),
                  io::display_encode(reference.mean));
}

// cell.json's record of a reference a frame was scored against: how it was rendered and stopped.
json reference_entry(uint32_t frame, const std::string& class_name,
                     const std::string& reference_name, const trace::ReferenceImage& reference) {
  return {{"frame", frame},
          {"path_class", class_name},
          {"reference", reference_name},
          {"samples", reference.samples},
          {"seconds", reference.seconds},
          {"rel_error", reference.rel_error},
          {"stopped_by", trace::stop_rule_name(reference.stopped_by)},
          {"max_bounces", reference.max_bounces}};
}

}  // namespace

ScoreResult score_cell(const config::Config& config, const Cell& cell, const scene::Scene& scene,
                       const std::vector<uint32_t>& frames, const std::string& path_class,
                       const std::filesystem::path& cell_dir,
                       const std::vector<trace::PathClass>& class_outputs) {
  ScoreResult result;
  std::vector<std::string> header = csv_header(config.metrics);
  io::CsvAppender metrics_csv(cell_dir / "metrics.csv", header);
  if (frames.empty() || config.metrics.empty()) return result;

  const std::vector<trace::PathClass> classes =
      scored_classes(path_class, class_outputs, result.warnings);
  trace::ReferenceCache cache(config.reference.cache_dir);
  const std::vector<ScoredReference> references = scored_references(config, cell);
  // reference name -> class -> rows
  std::map<std::string, std::map<trace::PathClass, std::vector<Row>>> rows;
  std::map<std::pair<std::string, trace::PathClass>, ScoredFrame> previous;
  for (uint32_t f : frames) {
    const io::Image output =
        io::read_image(cell_dir / "images" / fmt::format("frame_{:04d}.exr", f));
    scene::FrameState state = scene.at(f);
    for (trace::PathClass c : classes) {
      std::string name(trace::path_class_name(c));
      const bool handed_back =
          std::find(class_outputs.begin(), class_outputs.end(), c) != class_outputs.end();
      bool alone =
          handed_back || (c != trace::PathClass::combined && c != trace::PathClass::direct);
      std::filesystem::path alone_file = cell_dir / "images" / class_image_name(f, c);
      if (alone && !std::filesystem::exists(alone_file)) {
        result.warnings.push_back(fmt::format(
            "frame {}: the technique handed no indirect estimate to shade(); class '{}' not scored",
            f, name));
        continue;
      }
      const io::Image test = alone ? io::read_image(alone_file) : output;
      for (const ScoredReference& ref : references) {
        const trace::ReferenceImage reference =
            cache.get_or_render_entry(scene, state, c, test.width, test.height, ref.options);
        io::Image error_map;
        const bool full = ref.name == "full";
        auto before = previous.find({ref.name, c});
        const bool consecutive = before != previous.end() && before->second.frame + 1 == f;
        const bool flip = named(config.metrics, "flip");
        Row row = written_columns(score_row(reference, test, full && flip ? &error_map : nullptr,
                                            consecutive ? &before->second : nullptr, {flip}),
                                  config.metrics);
        std::vector<std::string> fields = {std::to_string(f), name, ref.name};
        for (size_t k = 3; k < header.size(); ++k)
          fields.push_back(csv_value(header[k], row[header[k]]));
        metrics_csv.row(fields);
        // The report's images show the full reference only.
        if (full) write_report_images(cell_dir, f, name, reference, flip ? &error_map : nullptr);
        rows[ref.name][c].push_back(std::move(row));
        previous[{ref.name, c}] = {f, test, reference};
        result.references.push_back(reference_entry(f, name, ref.name, reference));
      }
    }
  }
  for (const ScoredReference& ref : references) {
    json means = json::object();
    for (trace::PathClass c : classes)
      means[std::string(trace::path_class_name(c))] =
          class_means(rows[ref.name][c], config.metrics);
    if (ref.name != "full") means["max_bounces"] = ref.options.max_bounces;
    (ref.name == "full" ? result.means : result.bounce_matched_means) = std::move(means);
  }
  return result;
}

}  // namespace pb::run
