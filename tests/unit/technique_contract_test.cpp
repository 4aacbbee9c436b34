// The contract every technique plugin keeps, checked on each built plugin the same way, in the
// order a run meets it: the plugin loads and its descriptor creates and destroys an instance; the
// plan fills in every schema default; and it refuses each parameter outside its schema (a number
// beyond either end of its range, a flag that is not a boolean, a choice not offered, a key the
// schema does not have), naming the config's file, line and key, before anything runs. Each
// technique's own tests then go on from here: its closed forms, then its statistics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "photonbench/error.h"
#include "plan/plan.h"
#include "plan/plugins.h"
#include "plan_scratch.h"

namespace pb::run::technique_contract {

// The technique folders the build made plugins of (techniques/<name>/, PB_BUILT_TECHNIQUES from
// tests/CMakeLists.txt): each must be among the built plugins, so that the contract below cannot
// pass by finding none.
std::vector<std::string> built_technique_folders() {
  std::vector<std::string> names;
  std::stringstream list(PB_BUILT_TECHNIQUES);
  for (std::string name; std::getline(list, name, ',');) names.push_back(name);
  return names;
}

// The technique plugins the build made (PB_BINARY_DIR/plugins: the techniques, not the test
// plugins of tests/plugins).
const std::filesystem::path kTechniquePluginDir = PB_BINARY_DIR "/plugins";

std::vector<std::string> built_plugins() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(kTechniquePluginDir, ec))
    if (entry.path().extension() == ".so") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

// A config whose only technique entry sets `params` (a YAML flow mapping) on line 6.
std::string config_with(const std::string& technique, const std::string& params) {
  return "name: contract\n"
         "resolution: [64, 36]\n"
         "frames: {warmup: 0, count: 1, metrics_every: 0}\n"
         "scenes: [cornell-box]\n"
         "techniques:\n"
         "  - {technique: " +
         technique + ", params: " + params + "}\n";
}

// A value the spec refuses on each side of it: below and above a finite range, a word for a
// flag, an unknown choice.
std::vector<std::string> refused_values(const pb_param_spec& spec) {
  std::vector<std::string> out;
  auto text = [&spec](double v) {
    std::ostringstream s;
    if (spec.type == PB_PARAM_INT)
      s << std::llround(v);
    else
      s << v;
    return s.str();
  };
  const double step = spec.type == PB_PARAM_INT ? 1.0 : 0.5 + 0.01 * std::abs(spec.max_value);
  switch (spec.type) {
    case PB_PARAM_INT:
    case PB_PARAM_FLOAT:
      if (std::isfinite(spec.min_value) && spec.min_value > -1e15)
        out.push_back(text(spec.min_value - step));
      if (std::isfinite(spec.max_value) && spec.max_value < 1e15)
        out.push_back(text(spec.max_value + step));
      break;
    case PB_PARAM_BOOL:
      out.push_back("sometimes");
      break;
    case PB_PARAM_ENUM:
      out.push_back("no_such_choice");
      break;
  }
  return out;
}

TEST(TechniqueContractCoverage, EveryBuiltTechniqueFolderIsAPlugin) {
  const std::vector<std::string> built = built_plugins();
  const std::vector<std::string> folders = built_technique_folders();
  ASSERT_FALSE(folders.empty()) << "the build names no technique folder";
  for (const std::string& name : folders)
    EXPECT_NE(std::find(built.begin(), built.end(), name), built.end())
        << name << " is not among the plugins in " << kTechniquePluginDir;
}

// configs/quick.yaml, the default job (README's first command), runs every built technique: a
// technique joins it in the commit that adds the technique.
TEST(TechniqueContractCoverage, QuickConfigRunsEveryBuiltTechnique) {
  const RunPlan plan = plan_run(PB_SOURCE_DIR "/configs/quick.yaml",
                                {"plugin_dirs+=" + kTechniquePluginDir.string()});
  for (const std::string& name : built_technique_folders())
    EXPECT_TRUE(std::any_of(plan.cells.begin(), plan.cells.end(),
                            [&](const Cell& cell) { return cell.technique == name; }))
        << "configs/quick.yaml runs no cell of " << name;
}

class TechniqueContract : public ::testing::TestWithParam<std::string> {
 protected:
  TechniqueContract() : registry_({kTechniquePluginDir}) {}
  const pb_technique_descriptor& descriptor() {
    const Plugin* plugin = registry_.find(GetParam());
    EXPECT_TRUE(plugin && plugin->loaded())
        << GetParam() << ": " << (plugin ? plugin->load_error : "");
    if (!plugin || !plugin->loaded()) throw std::runtime_error("plugin did not load");
    return *plugin->descriptor;
  }
  PluginRegistry registry_;
  testing::PlanScratch scratch_{"technique_contract"};
};

TEST_P(TechniqueContract, LoadsAndCreatesAnInstance) {
  const pb_technique_descriptor& d = descriptor();
  EXPECT_EQ(std::string(d.name), GetParam()) << "the descriptor's name is its file's";
  EXPECT_GT(d.param_count, 0u);
  TechniqueInstance technique = create_technique(d);
  EXPECT_NE(technique.get(), nullptr);
}

TEST_P(TechniqueContract, ThePlanFillsInEveryDefault) {
  const pb_technique_descriptor& d = descriptor();
  const RunPlan plan = scratch_.plan(config_with(GetParam(), "{}"));
  ASSERT_EQ(plan.cells.size(), 1u);
  const auto& params = plan.cells[0].params;
  EXPECT_EQ(params.size(), d.param_count);
  for (uint32_t i = 0; i < d.param_count; ++i) {
    auto it = params.find(d.params[i].name);
    ASSERT_NE(it, params.end()) << d.params[i].name;
    if (d.params[i].type == PB_PARAM_INT || d.params[i].type == PB_PARAM_FLOAT)
      EXPECT_DOUBLE_EQ(std::stod(it->second), d.params[i].default_value) << d.params[i].name;
  }
}

TEST_P(TechniqueContract, RefusesEachParameterOutsideItsSchemaNamingFileLineAndKey) {
  const pb_technique_descriptor& d = descriptor();
  size_t tried = 0;
  for (uint32_t i = 0; i < d.param_count; ++i) {
    const pb_param_spec& spec = d.params[i];
    for (const std::string& value : refused_values(spec)) {
      ++tried;
      const std::string params = std::string("{") + spec.name + ": " + value + "}";
      try {
        (void)scratch_.plan(config_with(GetParam(), params));
        ADD_FAILURE() << GetParam() << ": " << params << " was accepted";
      } catch (const InputError& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("config.yaml:6:"), std::string::npos) << message;
        EXPECT_NE(message.find(spec.name), std::string::npos) << message;
      }
    }
  }
  EXPECT_GE(tried, d.param_count) << "every parameter refuses at least one value";
  try {
    (void)scratch_.plan(config_with(GetParam(), "{no_such_parameter: 1}"));
    ADD_FAILURE() << GetParam() << ": an unknown parameter was accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("config.yaml:6:"), std::string::npos) << message;
    EXPECT_NE(message.find("no_such_parameter"), std::string::npos) << message;
  }
}

INSTANTIATE_TEST_SUITE_P(Built, TechniqueContract, ::testing::ValuesIn(built_plugins()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

}  // namespace pb::run::technique_contract
