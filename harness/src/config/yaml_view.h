// A YAML node with the file it came from and its key path, so that every error reads
// "file:line:col: key.path: what is wrong". Config files and scene files are both read through it.
// Reading is explicit: a mapping declares its allowed keys with `allow_keys`, and any other key is
// an error that suggests the closest allowed name. Every number is read with a finite range (there
// is no unbounded accessor): a value outside it, NaN or infinity is an error at its key.
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

// A YAML document is at most this many bytes and, with its aliases expanded, this many nodes: an
// alias bomb ("billion laughs") is an error, not a hang.
inline constexpr size_t kMaxYamlBytes = size_t(16) << 20;
inline constexpr size_t kMaxYamlNodes = 1000000;

// Where a document came from: its file, and the values --set replaced in it (by key path, in
// YamlView's "a.b[0].c" form), so an error inside one says "--set ..." instead of a position in a
// text that is not the file.
struct YamlSource {
  std::string name;
  struct Override {
    std::string key_path;
    std::string assignment;
  };
  std::vector<Override> overrides;
};

class YamlView {
 public:
  // Both throw pb::InputError naming the file, line and column of a syntax error, a key written
  // twice in one mapping or a key that is not a plain scalar.
  static YamlView load_file(const std::filesystem::path& file);
  static YamlView parse(const std::string& text, const std::string& source_name);

  YamlView(YAML::Node node, std::shared_ptr<const YamlSource> source, std::string key_path);

  const YAML::Node& node() const { return node_; }
  const std::string& key_path() const { return key_path_; }
  const std::string& source() const { return source_->name; }
  // "file:line:col", 1-based; a value --set replaced says "file (--set key=value)", a document
  // without a position (an empty file) just "file".
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

  // Scalars, each checked; the message names the expected type or range. Numbers are finite and
  // inside [min, max] (both finite); vectors check every component.
  std::string as_string() const;
  double as_number(double min, double max) const;
  int64_t as_int(int64_t min, int64_t max) const;  // accepts 2e5 when it is integral
  bool as_bool() const;
  std::string as_enum(std::initializer_list<std::string_view> choices) const;
  glm::vec2 as_vec2(double min, double max) const;  // [x, y], or one number for both
  glm::vec3 as_vec3(double min, double max) const;  // [x, y, z], or one number for all three

  // Optional keys with a default.
  std::string string_or(std::string_view key, const std::string& fallback) const;
  double number_or(std::string_view key, double fallback, double min, double max) const;
  int64_t int_or(std::string_view key, int64_t fallback, int64_t min, int64_t max) const;
  bool bool_or(std::string_view key, bool fallback) const;

 private:
  std::string child_path(std::string_view key) const;
  double parse_number() const;
  const YamlSource::Override* override_here() const;

  YAML::Node node_;
  std::shared_ptr<const YamlSource> source_;
  std::string key_path_;
};

// What YamlView::parse checks beyond the syntax, for a tree built otherwise (--set): no mapping
// with a key twice or a key that is not a scalar, at most kMaxYamlNodes nodes with aliases
// expanded. Throws pb::InputError.
void check_yaml_tree(const YAML::Node& root, const std::string& source_name);

// The closest name to `word` among `candidates` (edit distance), or "" when none is close.
std::string closest_name(std::string_view word, const std::vector<std::string>& candidates);

// `text` for an error message: at most `max_chars` characters (then "..."), control and non-ASCII
// bytes as \xNN, so an error never echoes a whole line of whatever file it was given.
std::string quote(std::string_view text, size_t max_chars = 40);

// The whole of a regular file of at most `max_bytes`; pb::InputError "<file>: <what is wrong>" for
// a missing file, a directory, a device (/dev/zero never ends) or a larger file. `what` names the
// kind of file in the message ("scene file").
std::string read_text_file(const std::filesystem::path& file, size_t max_bytes, const char* what);

}  // namespace pb::config
