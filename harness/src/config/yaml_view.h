// A YAML node with the file it came from and its key path, so that every error reads
// "file:line:col: key.path: what is wrong". Config files and scene files are both read through it.
// Reading is explicit: a mapping declares its allowed keys with `allow_keys`, and any other key is
// an error that suggests the closest allowed name.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace pb::config {

class YamlView {
 public:
  // Both throw pb::InputError naming the file, line and column of a syntax error.
  static YamlView load_file(const std::filesystem::path& file);
  static YamlView parse(const std::string& text, const std::string& source_name);

  YamlView(YAML::Node node, std::shared_ptr<const std::string> source, std::string key_path);

  const YAML::Node& node() const { return node_; }
  const std::string& key_path() const { return key_path_; }
  const std::string& source() const { return *source_; }
  // "file:line:col", 1-based; nodes made by a --set override say so instead of a line.
  std::string location() const;
  [[noreturn]] void fail(const std::string& message) const;

  bool is_map() const { return node_.IsMap(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool is_scalar() const { return node_.IsScalar(); }

  // Mappings.
  bool has(std::string_view key) const;
  YamlView operator[](std::string_view key) const;  // required key: error if missing
  std::optional<YamlView> get(std::string_view key) const;
  std::vector<std::pair<std::string, YamlView>> entries() const;  // in file order
  void allow_keys(std::initializer_list<std::string_view> keys) const;
  void allow_keys(const std::vector<std::string>& keys) const;

  // Sequences.
  size_t size() const;
  YamlView operator[](size_t index) const;
  std::vector<YamlView> elements() const;  // a scalar reads as a one-element list

  // Scalars, each checked; the message names the expected type or range.
  std::string as_string() const;
  double as_number() const;
  double as_number(double min, double max) const;
  int64_t as_int(int64_t min, int64_t max) const;  // accepts 2e5 when it is integral
  bool as_bool() const;
  std::string as_enum(std::initializer_list<std::string_view> choices) const;
  glm::vec2 as_vec2() const;
  glm::vec3 as_vec3() const;  // [x, y, z], or one number for all three

  // Optional keys with a default.
  std::string string_or(std::string_view key, const std::string& fallback) const;
  double number_or(std::string_view key, double fallback, double min, double max) const;
  int64_t int_or(std::string_view key, int64_t fallback, int64_t min, int64_t max) const;
  bool bool_or(std::string_view key, bool fallback) const;
  glm::vec3 vec3_or(std::string_view key, glm::vec3 fallback) const;

 private:
  std::string child_path(std::string_view key) const;

  YAML::Node node_;
  std::shared_ptr<const std::string> source_;
  std::string key_path_;
};

// The closest name to `word` among `candidates` (edit distance), or "" when none is close.
std::string closest_name(std::string_view word, const std::vector<std::string>& candidates);

}  // namespace pb::config
