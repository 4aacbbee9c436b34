// The config's reference block (config.h ReferenceSettings): stop rules and truncation, checked
// like every key (errors name file:line:col and the key), and mapped onto the renderer's options.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>

#include "cell/scoring.h"
#include "config/config.h"
#include "config/reference_rules.h"
#include "photonbench/error.h"

namespace pb {
namespace reference_config_test {

std::filesystem::path write_config(const std::string& reference_block) {
  // Per test process: CTest runs this file's tests side by side.
  auto file = std::filesystem::path(::testing::TempDir()) /
              ("pb_reference_config_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(file) << "name: t\nresolution: [64, 36]\nscenes: [" PB_SOURCE_DIR
                         "/scenes/cornell-box.yaml]\ntechniques:\n  - technique: direct\n"
                      << reference_block;
  return file;
}

std::string load_error(const std::string& reference_block) {
  try {
    config::load_config(write_config(reference_block), {});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ReferenceConfig, DefaultIsAnErrorTargetWithATimeLimit) {
  config::Config c = config::load_config(write_config(""), {});
  EXPECT_GT(c.reference.rel_error, 0.0);
  EXPECT_GT(c.reference.max_seconds, 0.0);
  EXPECT_EQ(c.reference.samples, 0u);
  EXPECT_EQ(c.reference.max_bounces, 0u);
  trace::ReferenceOptions o = run::reference_options(c, 0);
  EXPECT_FLOAT_EQ(o.rel_error, float(c.reference.rel_error));
  EXPECT_EQ(o.samples, 0u);
}

TEST(ReferenceConfig, NamedStopRulesReplaceTheDefaults) {
  config::Config c = config::load_config(write_config("reference: {samples: 1024}\n"), {});
  EXPECT_EQ(c.reference.samples, 1024u);
  EXPECT_EQ(c.reference.rel_error, 0.0);
  EXPECT_EQ(c.reference.max_seconds, 0.0);
  c = config::load_config(
      write_config("reference: {rel_error: 0.02, max_seconds: 90, max_bounces: 4}\n"), {});
  trace::ReferenceOptions o = run::reference_options(c, 0);
  EXPECT_FLOAT_EQ(o.rel_error, 0.02f);
  EXPECT_EQ(o.max_seconds, 90.0);
  EXPECT_EQ(o.samples, 0u);
  EXPECT_EQ(o.max_bounces, 4u);
}

// A scene entry's stop rules replace the config's for that scene's cells alone, as a reference
// block's do (naming any uses those alone); the block's other keys hold for every scene.
TEST(ReferenceConfig, ASceneEntrysStopRulesReplaceTheConfigsForItsCells) {
  const std::string scenes =
      "scenes: [{scene: " PB_SOURCE_DIR
      "/scenes/cornell-box.yaml, reference: {rel_error: 0.03}}, " PB_SOURCE_DIR
      "/scenes/cornell-spot.yaml]\n";
  auto file = write_config("reference: {rel_error: 0.1, max_seconds: 60, estimator: pt}\n");
  std::string text;
  {
    std::ifstream in(file);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const size_t at = text.find("scenes: [");
  text.replace(at, text.find('\n', at) + 1 - at, scenes);
  std::ofstream(file) << text;
  const config::Config c = config::load_config(file, {});
  ASSERT_EQ(c.scenes.size(), 2u);
  const trace::ReferenceOptions own = run::reference_options(c, 0);
  EXPECT_FLOAT_EQ(own.rel_error, 0.03f);
  EXPECT_EQ(own.max_seconds, 0.0);  // named rules alone
  EXPECT_EQ(own.samples, 0u);
  EXPECT_EQ(own.estimator, trace::Estimator::pt);
  const trace::ReferenceOptions other = run::reference_options(c, 1);
  EXPECT_FLOAT_EQ(other.rel_error, 0.1f);
  EXPECT_EQ(other.max_seconds, 60.0);
  EXPECT_EQ(other.estimator, trace::Estimator::pt);
}

TEST(ReferenceConfig, BadValuesNameFileLineColumnAndKey) {
  EXPECT_NE(load_error("reference: {rel_eror: 0.1}\n")
                .find("reference.rel_eror: unknown key; did "
                      "you mean 'rel_error'"),
            std::string::npos)
      << load_error("reference: {rel_eror: 0.1}\n");
  std::string e = load_error("reference: {rel_error: 2}\n");
  EXPECT_NE(e.find(write_config("").filename().string() + ":6:"), std::string::npos) << e;
  EXPECT_NE(e.find("reference.rel_error"), std::string::npos) << e;
  e = load_error("reference: {samples: 1}\n");
  EXPECT_NE(e.find("reference.samples: 0 (off) or at least 2"), std::string::npos) << e;
  e = load_error("reference: {rel_error: 0, samples: 0}\n");
  EXPECT_NE(e.find("no rule would stop a reference"), std::string::npos) << e;
  e = load_error("reference: {max_bounces: 65}\n");
  EXPECT_NE(e.find("reference.max_bounces"), std::string::npos) << e;
}

// One rule for the config, `photonbench reference` and the renderer: ReferenceOptions::validate
// refuses what the config's reference block refuses, with the same words.
TEST(ReferenceConfig, TheRendererRefusesTheStopRulesTheConfigRefuses) {
  auto validate_error = [](float rel_error, double max_seconds, uint32_t samples) -> std::string {
    trace::ReferenceOptions o;
    o.rel_error = rel_error, o.max_seconds = max_seconds, o.samples = samples;
    try {
      o.validate();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(validate_error(0.05f, 0, 1).find("samples: 0 (off) or at least 2 iterations"),
            std::string::npos);
  EXPECT_NE(
      load_error("reference: {samples: 1}\n").find("samples: 0 (off) or at least 2 iterations"),
      std::string::npos);
  const std::string all_off = "rel_error, max_seconds and samples are all 0: no rule would stop";
  EXPECT_NE(validate_error(0, 0, 0).find(all_off), std::string::npos);
  EXPECT_NE(load_error("reference: {rel_error: 0, samples: 0}\n").find(all_off), std::string::npos);
  for (uint32_t samples : {0u, 2u, 256u})
    EXPECT_EQ(validate_error(samples ? 0.f : 0.05f, 0, samples), "") << samples;
  EXPECT_EQ(validate_error(0, 10, 0), "");
}

// The estimator names: each one the config accepts is an Estimator of that name, and the
// config's default is the automatic choice.
TEST(ReferenceConfig, EstimatorNamesAreTheRenderersEstimators) {
  ASSERT_EQ(config::estimator_names().size(), 3u);
  for (const std::string& name : config::estimator_names()) {
    config::Config c =
        config::load_config(write_config("reference: {estimator: " + name + "}\n"), {});
    std::optional<trace::Estimator> e = trace::parse_estimator(c.reference.estimator);
    ASSERT_TRUE(e) << name;
    EXPECT_EQ(trace::estimator_name(*e), name);
    EXPECT_EQ(run::reference_options(c, 0).estimator, *e);
  }
  EXPECT_EQ(run::reference_options(config::load_config(write_config(""), {}), 0).estimator,
            trace::Estimator::automatic);
  EXPECT_NE(load_error("reference: {estimator: bdtp}\n").find("did you mean 'bdpt'?"),
            std::string::npos);
}

// The light sampler names: each one the config accepts is the renderer's LightSelection of that
// name, power by default, and a misspelt one is refused naming the key.
TEST(ReferenceConfig, LightSamplerNamesAreTheRenderersLightChoices) {
  ASSERT_EQ(config::light_sampler_names().size(), 2u);
  for (const std::string& name : config::light_sampler_names()) {
    config::Config c =
        config::load_config(write_config("reference: {light_sampler: " + name + "}\n"), {});
    std::optional<trace::LightSelection> s =
        trace::parse_light_selection(c.reference.light_sampler);
    ASSERT_TRUE(s) << name;
    EXPECT_EQ(trace::light_selection_name(*s), name);
    EXPECT_EQ(run::reference_options(c, 0).light_selection, *s);
  }
  EXPECT_EQ(run::reference_options(config::load_config(write_config(""), {}), 0).light_selection,
            trace::LightSelection::power);
  std::string error = load_error("reference: {light_sampler: bhv}\n");
  EXPECT_NE(error.find("light_sampler"), std::string::npos) << error;
  EXPECT_NE(error.find("did you mean 'bvh'?"), std::string::npos) << error;
}

}  // namespace reference_config_test
}  // namespace pb
