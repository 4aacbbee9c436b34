// The one mechanism every number of a config or scene goes through (config/yaml_view.h): finite,
// inside its range, at its key; and where a value came from (the file's line, or a --set).
#include "config/config.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "config/yaml_view.h"
#include "photonbench/error.h"

namespace pb::config {
namespace config_test {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(YamlNumbers, AreFiniteAndInsideTheirRange) {
  YamlView root = YamlView::parse("a: 1.5\nb: nan\nc: 1e999\nd: [1, 2, 1e23]\ne: inf\nf: 7\n", "t");
  EXPECT_EQ(root["a"].as_number(0, 2), 1.5);
  EXPECT_EQ(error_of([&] { root["a"].as_number(0, 1); }),
            "t:1:4: a: value 1.5 is out of range [0, 1]");
  EXPECT_EQ(error_of([&] { root["b"].as_number(-1e6, 1e6); }),
            "t:2:4: b: expected a finite number, got 'nan'");
  EXPECT_EQ(error_of([&] { root["c"].as_number(-1e6, 1e6); }),
            "t:3:4: c: '1e999' is beyond the range of a double");
  EXPECT_EQ(error_of([&] { root["d"].as_vec3(-1e6, 1e6); }),
            "t:4:11: d[2]: value 1e23 is out of range [-1000000, 1000000]");
  EXPECT_EQ(error_of([&] { root["e"].as_int(0, 10); }),
            "t:5:4: e: expected a finite number, got 'inf'");
  EXPECT_EQ(root["f"].as_int(0, 10), 7);
  EXPECT_EQ(error_of([&] { root["a"].as_int(0, 10); }), "t:1:4: a: expected an integer, got '1.5'");
}

TEST(YamlDocuments, RejectDuplicateKeysComplexKeysAndAliasBombs) {
  EXPECT_EQ(error_of([] { YamlView::parse("a: 1\nb: {c: 1, c: 2}\n", "t"); }),
            "t:2:11: key 'c' is written twice in this mapping (first at line 2); one of them "
            "would be ignored");
  EXPECT_EQ(error_of([] { YamlView::parse("? [1, 2]\n: 3\n", "t"); }),
            "t:1:3: a key must be a plain name, not a list or a mapping");
  std::string bomb = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i <= 6; ++i) {
    std::string p = "*a" + std::to_string(i - 1);
    bomb += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [" + p;
    for (int k = 1; k < 10; ++k) bomb += ", " + p;
    bomb += "]\n";
  }
  EXPECT_NE(error_of([&] { YamlView::parse(bomb, "t"); }).find("expands to more than 1000000"),
            std::string::npos);
}

TEST(YamlMessages, QuoteLongAndBinaryValues) {
  EXPECT_EQ(quote("abc"), "abc");
  EXPECT_EQ(quote(std::string(50, 'x'), 10), "xxxxxxxxxx...");
  EXPECT_EQ(quote(std::string("a\nb\x01\xff", 5)), "a\\x0ab\\x01\\xff");
}

TEST(Overrides, NameTheKeyPathAndTheAssignment) {
  YAML::Node root = YAML::Load("techniques: [{technique: direct}]\nframes: {count: 2}\n");
  EXPECT_EQ(apply_override(root, "frames.count=3"), "frames.count");
  EXPECT_EQ(apply_override(root, "techniques.0.params={a: 1}"), "techniques[0].params");
  EXPECT_EQ(apply_override(root, "plugin_dirs+=x"), "plugin_dirs[0]");
  EXPECT_EQ(apply_override(root, "plugin_dirs+=y"), "plugin_dirs[1]");
  EXPECT_EQ(error_of([&] { apply_override(root, "techniques.99999999999999999999=1"); }),
            "--set techniques.99999999999999999999=1: 'techniques' has 1 elements, no element "
            "99999999999999999999");
  EXPECT_EQ(error_of([&] { apply_override(root, "=1"); }), "--set =1: expected key.path=value");
  EXPECT_NE(error_of([&] { apply_override(root, "a..b=1"); }).find("no empty part"),
            std::string::npos);

  const auto file = std::filesystem::temp_directory_path() /
                    ("pb_config_test_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(file) << "scenes: [cornell-box]\ntechniques: [{technique: direct}]\n";
  // An error in a value --set replaced names the --set; one in the file names its line.
  std::string message = error_of([&] { load_config(file, {"frames.count=-3"}); });
  EXPECT_NE(message.find(".yaml (--set frames.count=-3): frames.count: value -3 is out of range"),
            std::string::npos)
      << message;
  message = error_of([&] { load_config(file, {"reference={samples: nan}"}); });
  EXPECT_NE(message.find("(--set reference={samples: nan}): reference.samples: expected a finite"),
            std::string::npos)
      << message;
  message = error_of([&] { load_config(file, {"name=../up"}); });
  EXPECT_NE(message.find("name: '../up' is not a folder name"), std::string::npos) << message;
  std::filesystem::remove(file);
  EXPECT_EQ(folder_safe_name("my config (2)"), "my-config--2-");
  EXPECT_EQ(folder_safe_name(".hidden"), "x.hidden");
}

TEST(Files, AreRegularAndBounded) {
  EXPECT_NE(error_of([] {
              read_text_file("/dev/zero", 1024, "test file");
            }).find("/dev/zero: is not a regular file"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              read_text_file("/tmp", 1024, "test file");
            }).find("/tmp: is a directory, not a test file"),
            std::string::npos);
  const auto file =
      std::filesystem::temp_directory_path() / ("pb_config_test_big_" + std::to_string(::getpid()));
  std::ofstream(file) << std::string(2048, 'x');
  EXPECT_EQ(read_text_file(file, 2048, "test file").size(), 2048u);
  EXPECT_NE(error_of([&] { read_text_file(file, 2047, "test file"); }).find("larger than"),
            std::string::npos);
  // Larger than the reader's chunks: read whole and in order, and bounded to the byte.
  std::string text;
  for (int i = 0; text.size() < 300000; ++i) text += std::to_string(i) + '\n';
  std::ofstream(file, std::ios::trunc) << text;
  EXPECT_EQ(read_text_file(file, text.size(), "test file"), text);
  EXPECT_NE(
      error_of([&] { read_text_file(file, text.size() - 1, "test file"); }).find("larger than"),
      std::string::npos);
  std::filesystem::remove(file);
}

}  // namespace config_test
}  // namespace pb::config
