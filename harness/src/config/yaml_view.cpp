#include "config/yaml_view.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "photonbench/error.h"

namespace pb::config {

namespace {

size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string closest_name(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::max<size_t>(3, word.size() / 3) + 1;
  for (const auto& candidate : candidates) {
    size_t d = edit_distance(word, candidate);
    if (d < best_distance) best_distance = d, best = candidate;
  }
  return best;
}

YamlView YamlView::load_file(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!std::filesystem::is_regular_file(file) || !in)
    throw InputError(fmt::format("{}: cannot open file", file.string()));
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), file.string());
}

YamlView YamlView::parse(const std::string& text, const std::string& source_name) {
  try {
    return YamlView(YAML::Load(text), std::make_shared<const std::string>(source_name), "");
  } catch (const YAML::ParserException& e) {
    throw InputError(fmt::format("{}:{}:{}: YAML syntax error: {}", source_name, e.mark.line + 1,
                                 e.mark.column + 1, e.msg));
  }
}

YamlView::YamlView(YAML::Node node, std::shared_ptr<const std::string> source, std::string key_path)
    : node_(std::move(node)), source_(std::move(source)), key_path_(std::move(key_path)) {}

std::string YamlView::location() const {
  YAML::Mark mark = node_.Mark();
  if (mark.is_null()) return *source_ + " (set on the command line)";
  return fmt::format("{}:{}:{}", *source_, mark.line + 1, mark.column + 1);
}

void YamlView::fail(const std::string& message) const {
  if (key_path_.empty()) throw InputError(fmt::format("{}: {}", location(), message));
  throw InputError(fmt::format("{}: {}: {}", location(), key_path_, message));
}

std::string YamlView::child_path(std::string_view key) const {
  return key_path_.empty() ? std::string(key) : key_path_ + "." + std::string(key);
}

bool YamlView::has(std::string_view key) const {
  return node_.IsMap() && node_[std::string(key)].IsDefined();
}

YamlView YamlView::operator[](std::string_view key) const {
  if (!node_.IsMap()) fail("expected a mapping with key '" + std::string(key) + "'");
  YAML::Node child = node_[std::string(key)];
  if (!child.IsDefined()) fail(fmt::format("missing required key '{}'", key));
  return YamlView(child, source_, child_path(key));
}

std::optional<YamlView> YamlView::get(std::string_view key) const {
  if (!node_.IsMap()) {
    if (node_.IsNull() || !node_.IsDefined()) return std::nullopt;
    fail("expected a mapping");
  }
  YAML::Node child = node_[std::string(key)];
  if (!child.IsDefined()) return std::nullopt;
  return YamlView(child, source_, child_path(key));
}

std::vector<std::pair<std::string, YamlView>> YamlView::entries() const {
  std::vector<std::pair<std::string, YamlView>> out;
  if (node_.IsNull()) return out;
  if (!node_.IsMap()) fail("expected a mapping");
  for (const auto& item : node_) {
    auto key = item.first.as<std::string>();
    out.emplace_back(key, YamlView(item.second, source_, child_path(key)));
  }
  return out;
}

void YamlView::allow_keys(std::initializer_list<std::string_view> keys) const {
  allow_keys(std::vector<std::string>(keys.begin(), keys.end()));
}

void YamlView::allow_keys(const std::vector<std::string>& keys) const {
  if (node_.IsNull()) return;
  if (!node_.IsMap()) fail("expected a mapping");
  for (const auto& item : node_) {
    auto key = item.first.as<std::string>();
    if (std::find(keys.begin(), keys.end(), key) != keys.end()) continue;
    YamlView at(item.first, source_, child_path(key));
    std::string hint = closest_name(key, keys);
    std::string allowed;
    for (const auto& k : keys) allowed += (allowed.empty() ? "" : ", ") + k;
    at.fail(hint.empty()
                ? fmt::format("unknown key (allowed: {})", allowed)
                : fmt::format("unknown key; did you mean '{}'? (allowed: {})", hint, allowed));
  }
}

size_t YamlView::size() const {
  if (!node_.IsSequence()) fail("expected a list");
  return node_.size();
}

YamlView YamlView::operator[](size_t index) const {
  if (!node_.IsSequence() || index >= node_.size())
    fail(fmt::format("expected a list with an element {}", index));
  return YamlView(node_[index], source_, fmt::format("{}[{}]", key_path_, index));
}

std::vector<YamlView> YamlView::elements() const {
  std::vector<YamlView> out;
  if (node_.IsSequence()) {
    for (size_t i = 0; i < node_.size(); ++i) out.push_back((*this)[i]);
  } else if (node_.IsDefined() && !node_.IsNull()) {
    out.push_back(*this);
  }
  return out;
}

std::string YamlView::as_string() const {
  if (!node_.IsScalar()) fail("expected a string");
  return node_.Scalar();
}

double YamlView::as_number() const {
  if (!node_.IsScalar()) fail("expected a number");
  const std::string& text = node_.Scalar();
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value))
    fail(fmt::format("expected a number, got '{}'", text));
  return value;
}

double YamlView::as_number(double min, double max) const {
  double value = as_number();
  if (value < min || value > max)
    fail(fmt::format("value {} is out of range [{}, {}]", node_.Scalar(), min, max));
  return value;
}

int64_t YamlView::as_int(int64_t min, int64_t max) const {
  double value = as_number();
  if (value != std::floor(value))
    fail(fmt::format("expected an integer, got '{}'", node_.Scalar()));
  if (value < double(min) || value > double(max))
    fail(fmt::format("value {} is out of range [{}, {}]", node_.Scalar(), min, max));
  return int64_t(value);
}

bool YamlView::as_bool() const {
  if (node_.IsScalar()) {
    const std::string& s = node_.Scalar();
    if (s == "true" || s == "yes" || s == "on") return true;
    if (s == "false" || s == "no" || s == "off") return false;
  }
  fail("expected true or false");
}

std::string YamlView::as_enum(std::initializer_list<std::string_view> choices) const {
  std::string value = as_string();
  std::vector<std::string> names(choices.begin(), choices.end());
  if (std::find(names.begin(), names.end(), value) != names.end()) return value;
  std::string allowed;
  for (const auto& n : names) allowed += (allowed.empty() ? "" : ", ") + n;
  std::string hint = closest_name(value, names);
  fail(hint.empty()
           ? fmt::format("'{}' is not one of: {}", value, allowed)
           : fmt::format("'{}' is not one of: {}; did you mean '{}'?", value, allowed, hint));
}

glm::vec2 YamlView::as_vec2() const {
  if (node_.IsScalar()) return glm::vec2(float(as_number()));
  if (!node_.IsSequence() || node_.size() != 2) fail("expected [x, y]");
  return {float((*this)[size_t(0)].as_number()), float((*this)[size_t(1)].as_number())};
}

glm::vec3 YamlView::as_vec3() const {
  if (node_.IsScalar()) return glm::vec3(float(as_number()));
  if (!node_.IsSequence() || node_.size() != 3) fail("expected [x, y, z] or one number");
  return {float((*this)[size_t(0)].as_number()), float((*this)[size_t(1)].as_number()),
          float((*this)[size_t(2)].as_number())};
}

std::string YamlView::string_or(std::string_view key, const std::string& fallback) const {
  auto v = get(key);
  return v ? v->as_string() : fallback;
}

double YamlView::number_or(std::string_view key, double fallback, double min, double max) const {
  auto v = get(key);
  return v ? v->as_number(min, max) : fallback;
}

int64_t YamlView::int_or(std::string_view key, int64_t fallback, int64_t min, int64_t max) const {
  auto v = get(key);
  return v ? v->as_int(min, max) : fallback;
}

bool YamlView::bool_or(std::string_view key, bool fallback) const {
  auto v = get(key);
  return v ? v->as_bool() : fallback;
}

glm::vec3 YamlView::vec3_or(std::string_view key, glm::vec3 fallback) const {
  auto v = get(key);
  return v ? v->as_vec3() : fallback;
}

}  // namespace pb::config
