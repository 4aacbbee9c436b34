#include "run/seed_stats.h"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "cell/cell_runner.h"
#include "cell/scoring.h"
#include "io/image.h"
#include "io/results.h"
#include "metrics/metrics.h"
#include "metrics/z_test.h"
#include "reference/reference.h"
#include "scene/scene.h"

namespace pb::run {

using json = nlohmann::json;

namespace {

// Per pixel-channel mean and unbiased variance (K - 1 in the denominator) of K >= 2 images.
std::pair<io::Image, io::Image> mean_and_variance(const std::vector<io::Image>& images) {
  const io::Image& first = images.front();
  io::Image mean(first.width, first.height, first.channels), variance = mean;
  const double k = double(images.size());
  for (size_t i = 0; i < first.pixels.size(); ++i) {
    double sum = 0, sum_sq = 0;
    for (const io::Image& image : images) sum += image.pixels[i];
    const double m = sum / k;
    for (const io::Image& image : images) sum_sq += (image.pixels[i] - m) * (image.pixels[i] - m);
    mean.pixels[i] = float(m);
    variance.pixels[i] = float(sum_sq / (k - 1));
  }
  return {mean, variance};
}

io::Image scaled(io::Image image, double factor) {
  for (float& v : image.pixels) v = float(v * factor);
  return image;
}

// The relative standard deviation map, as an error map in [0, 1] (one channel: its luma).
io::Image relative_stddev(const io::Image& mean, const io::Image& variance) {
  io::Image map(mean.width, mean.height, 1, false);
  const int c = std::min(mean.channels, 3);
  for (size_t p = 0; p < mean.pixel_count(); ++p) {
    double rel = 0;
    for (int ch = 0; ch < c; ++ch) {
      const size_t i = p * size_t(mean.channels) + size_t(ch);
      rel += std::sqrt(std::max(0.f, variance.pixels[i])) / (std::abs(mean.pixels[i]) + 0.01);
    }
    map.pixels[p] = float(std::min(1.0, rel / c));
  }
  return map;
}

json z_test_json(const metrics::ZTestResult& z) {
  return {{"tested", z.tested},
          {"rejected", z.rejected},
          {"exact", z.exact},
          {"alpha", z.alpha},
          {"sidak_level", z.sidak_level},
          {"min_p", z.min_p},
          {"p_value", z.p_value},
          {"equal", z.equal()}};
}

// One group's K cells (seed order): its images, their statistics and Z-tests.
json summarise_group(const RunPlan& plan, const std::vector<const Cell*>& cells,
                     const std::vector<json>& records, const std::filesystem::path& run_dir) {
  const Cell& first = *cells.front();
  const std::filesystem::path out = run_dir / "seeds" / first.seed_group;
  std::filesystem::create_directories(out);
  const scene::Scene scene = scene::load_scene(first.scene_file);
  trace::ReferenceCache cache(plan.config.reference.cache_dir);
  const trace::ReferenceOptions options = reference_options(plan.config, first.scene_entry);
  json group = {{"group", first.seed_group},    {"scene", first.scene},
                {"technique", first.technique}, {"params", first.params},
                {"seeds", json::array()},       {"cells", json::array()},
                {"frames", json::array()}};
  for (const Cell* cell : cells) {
    group["seeds"].push_back(cell->seed);
    group["cells"].push_back(cell->id);
  }
  // The classes each cell was scored on, from its record (metrics: {class: means}).
  std::vector<std::string> classes;
  const json scored = records.front().value("metrics", json::object());
  for (auto it = scored.begin(); it != scored.end(); ++it) classes.push_back(it.key());
  for (uint32_t frame : metric_frames(plan.config))
    for (const std::string& name : classes) {
      const auto path_class = trace::parse_path_class(name);
      if (!path_class) continue;
      const bool alone =
          *path_class != trace::PathClass::combined && *path_class != trace::PathClass::direct;
      const std::string file =
          alone ? class_image_name(frame, *path_class) : fmt::format("frame_{:04d}.exr", frame);
      std::vector<io::Image> images;
      for (const Cell* cell : cells)
        images.push_back(io::read_image(cell_dir(run_dir, cell->id) / "images" / file));
      const auto [mean, variance] = mean_and_variance(images);
      const std::string suffix = fmt::format("{:04d}_{}", frame, name);
      io::write_image(out / ("mean_" + suffix + ".exr"), mean);
      io::write_image(out / ("variance_" + suffix + ".exr"), variance);
      io::write_image(out / ("stddev_" + suffix + ".png"),
                      metrics::magma(relative_stddev(mean, variance)));
      json row = {{"frame", frame}, {"path_class", name}};
      const auto reference =
          cache.get_entry(scene, scene.at(frame), *path_class, mean.width, mean.height, options);
      if (reference) {
        // The variance of the K-seed mean is S^2 / K; the reference's is its own, of its mean.
        row["z_test"] =
            z_test_json(metrics::z_test(mean, scaled(variance, 1.0 / double(cells.size())),
                                        reference->mean, reference->variance, kSeedZTestAlpha));
      } else {
        row["z_test"] = nullptr;
        row["z_test_missing"] = "the reference is not in the cache";
      }
      group["frames"].push_back(row);
    }
  io::write_text_atomic(out / "seeds.json", group.dump(2) + "\n");
  return group;
}

}  // namespace

void write_seed_statistics(const RunPlan& plan, const std::filesystem::path& run_dir) {
  if (plan.config.seeds <= 1) return;
  std::map<std::string, std::vector<const Cell*>> groups;  // the plan's cells, in seed order
  std::vector<std::string> order;
  for (const Cell& cell : plan.cells) {
    if (!groups.count(cell.seed_group)) order.push_back(cell.seed_group);
    groups[cell.seed_group].push_back(&cell);
  }
  json index = {{"alpha", kSeedZTestAlpha},
                {"seeds", plan.config.seeds},
                {"groups", json::array()},
                {"incomplete", json::array()}};
  for (const std::string& id : order) {
    const std::vector<const Cell*>& cells = groups[id];
    std::vector<json> records;
    std::string problem;
    for (const Cell* cell : cells) {
      const std::filesystem::path file = cell_dir(run_dir, cell->id) / "cell.json";
      if (!std::filesystem::exists(file)) {
        problem = fmt::format("cell {} did not complete", cell->id);
        break;
      }
      records.push_back(json::parse(io::read_text(file)));
      if (records.back().value("status", "") != "ok") {
        problem = fmt::format("cell {} failed", cell->id);
        break;
      }
    }
    if (problem.empty() && cells.size() < 2) problem = "fewer than two seeds";
    if (!problem.empty()) {
      index["incomplete"].push_back({{"group", id}, {"reason", problem}});
      continue;
    }
    try {
      summarise_group(plan, cells, records, run_dir);
      index["groups"].push_back(id);
    } catch (const std::exception& e) {
      index["incomplete"].push_back({{"group", id}, {"reason", e.what()}});
    }
  }
  io::write_text_atomic(run_dir / "seeds.json", index.dump(2) + "\n");
}

}  // namespace pb::run
