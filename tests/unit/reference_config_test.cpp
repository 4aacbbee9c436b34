// The config's reference block (config.h ReferenceSettings): stop rules and truncation, checked
// like every key (errors name file:line:col and the key), and mapped onto the renderer's options.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cell/scoring.h"
#include "config/config.h"
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
  trace::ReferenceOptions o = run::reference_options(c);
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
  trace::ReferenceOptions o = run::reference_options(c);
  EXPECT_FLOAT_EQ(o.rel_error, 0.02f);
  EXPECT_EQ(o.max_seconds, 90.0);
  EXPECT_EQ(o.samples, 0u);
  EXPECT_EQ(o.max_bounces, 4u);
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

}  // namespace reference_config_test
}  // namespace pb
