// Helpers for tests that run `photonbench run` end to end (technique tests): a scratch folder, a
// run of a YAML text (with Vulkan validation where CTest asks for it), and readers for the run's
// cells, counters and images.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/image.h"
#include "photonbench/error.h"
#include "plan/plan.h"
#include "validation.h"

namespace pb::testing {

namespace fs = std::filesystem;

// An empty folder under the temp dir, unique to this test process.
inline fs::path work_dir(const std::string& suite, const std::string& name) {
  fs::path dir =
      fs::temp_directory_path() / ("pb_" + suite + "_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Writes `yaml` to DIR/config.yaml and plans it in-process as `photonbench validate` does, with
// the build's plugins: the bad-input error it is refused with (file:line:col: key: why), or "" when
// it is valid.
inline std::string plan_error(const fs::path& dir, const std::string& yaml) {
  std::ofstream(dir / "config.yaml") << yaml;
  try {
    run::plan_run(dir / "config.yaml", {"plugin_dirs+=" PB_BINARY_DIR "/plugins"});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Writes `yaml` to DIR/config.yaml and runs it into DIR/run, with validation where validation_on();
// the console output goes to DIR/log.txt. Returns the exit status as std::system does.
inline int run_config(const fs::path& dir, const std::string& yaml) {
  std::ofstream(dir / "config.yaml") << yaml;
  std::string cmd = std::string(PB_BINARY_DIR "/photonbench run ") +
                    (dir / "config.yaml").string() + " --out " + (dir / "run").string() +
                    (validation_on() ? " --validation" : "") + " > " + (dir / "log.txt").string() +
                    " 2>&1";
  return std::system(cmd.c_str());
}

inline nlohmann::json read_json(const fs::path& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

// The cells of a run whose folder name starts with `prefix` (e.g. "cornell-box__tiled__"), sorted.
inline std::vector<fs::path> cells_with_prefix(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> found;
  for (const auto& entry : fs::directory_iterator(dir / "run" / "cells"))
    if (entry.path().filename().string().rfind(prefix, 0) == 0) found.push_back(entry.path());
  std::sort(found.begin(), found.end());
  return found;
}

inline fs::path cell_dir(const fs::path& dir, const std::string& prefix) {
  auto found = cells_with_prefix(dir, prefix);
  return found.empty() ? fs::path() : found.front();
}

// The cell whose technique is `technique` and whose resolved parameters include every pair of
// `params` (values as cell.json writes them: strings); empty if none.
inline fs::path find_cell(const fs::path& dir, const std::string& technique,
                          const std::map<std::string, std::string>& params = {}) {
  for (const auto& entry : fs::directory_iterator(dir / "run" / "cells")) {
    auto record = read_json(entry.path() / "cell.json");
    if (record["technique"] != technique) continue;
    bool match = true;
    for (const auto& [name, value] : params)
      match = match && record["params"].contains(name) && record["params"][name] == value;
    if (match) return entry.path();
  }
  return {};
}

// counters.csv of a cell, row by row: (frame, counter name, value). A cell without one (not run, or
// not found: an empty path) throws, so the test that asked fails saying so.
template <class Row>
void for_each_counter(const fs::path& cell, Row row) {
  std::ifstream in(cell / "counters.csv");
  if (!in) throw std::runtime_error("no counters.csv in the cell '" + cell.string() + "'");
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::string frame, name, value;
    std::getline(fields, frame, ',');
    std::getline(fields, name, ',');
    std::getline(fields, value, ',');
    row(std::stoi(frame), name, std::stod(value));
  }
}

// Each counter summed over the measured frames. A technique writes each of its counters every frame
// (zeros too), so a name the cell never wrote is a renamed or lost counter: reading it throws,
// naming the counters there are, where a std::map's operator[] would read 0 and let
// EXPECT_EQ(sums["overflows"], 0) pass.
class CounterSums {
 public:
  explicit CounterSums(const fs::path& cell) : cell_(cell) {
    for_each_counter(cell, [&](int, const std::string& name, double v) { sums_[name] += v; });
  }
  double operator[](const std::string& name) const { return at(name); }
  double at(const std::string& name) const {
    auto it = sums_.find(name);
    if (it != sums_.end()) return it->second;
    std::string written;
    for (const auto& [n, v] : sums_) written += (written.empty() ? "" : ", ") + n;
    throw std::out_of_range("no counter '" + name + "' in " + (cell_ / "counters.csv").string() +
                            " (it has: " + written + ")");
  }
  bool contains(const std::string& name) const { return sums_.count(name) != 0; }
  auto begin() const { return sums_.begin(); }
  auto end() const { return sums_.end(); }

 private:
  fs::path cell_;
  std::map<std::string, double> sums_;
};

inline CounterSums counters(const fs::path& cell) { return CounterSums(cell); }

// One counter's value per measured frame, in frame order.
inline std::vector<double> counter_series(const fs::path& cell, const std::string& counter) {
  std::map<int, double> by_frame;
  for_each_counter(cell, [&](int frame, const std::string& name, double v) {
    if (name == counter) by_frame[frame] += v;
  });
  std::vector<double> values;
  for (const auto& [frame, v] : by_frame) values.push_back(v);
  return values;
}

// images/frame_NNNN.exr, or with `path_class` the technique's estimate of that class alone
// (frame_NNNN_<class>.exr).
inline io::Image frame_image(const fs::path& cell, int frame = 0,
                             const std::string& path_class = "") {
  char name[64];
  std::snprintf(name, sizeof name, "frame_%04d%s%s.exr", frame, path_class.empty() ? "" : "_",
                path_class.c_str());
  return io::read_image(cell / "images" / name);
}

inline double mean_rgb(const io::Image& image) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) sum += image.at(x, y, c);
  return sum / (3.0 * image.pixel_count());
}

inline bool all_finite(const io::Image& image) {
  for (float v : image.pixels)
    if (!std::isfinite(v)) return false;
  return true;
}

// The warnings of a cell (cell.json), as one string to search.
inline std::string warnings(const fs::path& cell) {
  return read_json(cell / "cell.json")["warnings"].dump();
}

// The loop-budget boundary of a hierarchy splatter (splat_bench.h's budget_boundary fills it): one
// photon, profiled, gives the most loop steps an invocation took, M (the largest
// `profile_*_steps_max`); then loop_budget M and M - 1, and what each reported.
// expect_budget_boundary checks it: with M nothing is truncated (a walk whose last step takes the
// last unit is complete), with M - 1 some traversal is, counted and warned about.
struct BudgetBoundary {
  int most = 0;
  double photons = 0, truncated_unlimited = -1, truncated_at_most = -1, truncated_below = -1;
  std::string warnings_at_most, warnings_below;
};

inline void expect_budget_boundary(const BudgetBoundary& b) {
  ASSERT_EQ(b.photons, 1);
  ASSERT_EQ(b.truncated_unlimited, 0);
  ASSERT_GT(b.most, 2);
  EXPECT_EQ(b.truncated_at_most, 0) << "budget " << b.most;
  EXPECT_EQ(b.warnings_at_most.find("loop budget"), std::string::npos) << b.warnings_at_most;
  EXPECT_GE(b.truncated_below, 1) << "budget " << b.most - 1;
  EXPECT_NE(b.warnings_below.find("loop budget"), std::string::npos) << b.warnings_below;
}

// A Cornell box whose every surface is the same grey and whose light has the colour `rgb` (YAML
// "[r, g, b]"): every photon, and so every pixel of an exact estimate, has the light's channel
// ratios. Written to DIR/<name>.yaml; returns its path (a config names a scene by path).
inline fs::path grey_box_scene(const fs::path& dir, const std::string& name,
                               const std::string& rgb) {
  fs::path file = dir / (name + ".yaml");
  std::ofstream(file)
      << "purpose: channel ratios (tests)\n"
         "camera: {position: [0.5, 0.5, 2.44], target: [0.5, 0.5, 0.0], fov_deg: 39.3}\n"
         "lights:\n"
         "  - {name: ceiling, type: point, position: [0.5, 0.97, 0.5], intensity: 2.5, color: "
      << rgb
      << "}\n"
         "materials:\n"
         "  grey: {type: diffuse, albedo: [0.7, 0.7, 0.7]}\n"
         "objects:\n"
         "  - {name: floor, shape: {type: quad}, material: grey, transform: {translate: [0.5, 0, "
         "0.5]}}\n"
         "  - {name: ceiling, shape: {type: quad}, material: grey,\n"
         "     transform: {translate: [0.5, 1, 0.5], rotate_deg: [180, 0, 0]}}\n"
         "  - {name: back, shape: {type: quad}, material: grey,\n"
         "     transform: {translate: [0.5, 0.5, 0], rotate_deg: [90, 0, 0]}}\n"
         "  - {name: left, shape: {type: quad}, material: grey,\n"
         "     transform: {translate: [0, 0.5, 0.5], rotate_deg: [0, 0, -90]}}\n"
         "  - {name: right, shape: {type: quad}, material: grey,\n"
         "     transform: {translate: [1, 0.5, 0.5], rotate_deg: [0, 0, 90]}}\n"
         "  - {name: block, shape: {type: box, size: 0.3}, material: grey,\n"
         "     transform: {translate: [0.6, 0.15, 0.6], rotate_deg: [0, -17, 0]}}\n";
  return file;
}

// The largest relative deviation, over pixels whose channel `strong` exceeds `floor`, of channel
// `weak` / channel `strong` from `ratio`. expect_green_ratio: a cell's indirect image (of the grey
// box lit by [1, 1e-5, 1]) keeps green / red = 1e-5 to 1e-3 in every pixel brighter than 1e-4 of
// the mean.
inline double worst_channel_ratio(const io::Image& image, int weak, int strong, double ratio,
                                  double floor) {
  double worst = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      double s = image.at(x, y, strong);
      if (s <= floor) continue;
      worst = std::max(worst, std::abs(image.at(x, y, weak) / (s * ratio) - 1.0));
    }
  return worst;
}

inline void expect_green_ratio(const io::Image& image, const std::string& what = "") {
  double worst = worst_channel_ratio(image, 1, 0, 1e-5, 1e-4 * mean_rgb(image));
  EXPECT_LT(worst, 1e-3) << what << ": green / red off by " << worst;
}
inline void expect_green_ratio(const fs::path& cell) {
  expect_green_ratio(frame_image(cell, 0, "indirect"), cell.filename().string());
}

}  // namespace pb::testing
