#include "config/yaml_view.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <unordered_map>

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
  if (word.size() > 200) return best;  // no name is that long; spare the quadratic distance
  size_t best_distance = std::max<size_t>(3, word.size() / 3) + 1;
  for (const auto& candidate : candidates) {
    size_t d = edit_distance(word, candidate);
    if (d < best_distance) best_distance = d, best = candidate;
  }
  return best;
}

std::string quote(std::string_view text, size_t max_chars) {
  std::string out;
  size_t shown = 0;
  for (unsigned char c : text) {
    if (shown == max_chars) return out + "...";
    if (c < 0x20 || c >= 0x7f)
      out += fmt::format("\\x{:02x}", c);
    else
      out += char(c);
    ++shown;
  }
  return out;
}

std::string read_text_file(const std::filesystem::path& file, size_t max_bytes, const char* what) {
  std::error_code ec;
  auto status = std::filesystem::status(file, ec);
  if (ec || !std::filesystem::exists(status))
    throw InputError(fmt::format("{}: {} not found", file.string(), what));
  if (std::filesystem::is_directory(status))
    throw InputError(fmt::format("{}: is a directory, not a {}", file.string(), what));
  if (!std::filesystem::is_regular_file(status))
    throw InputError(fmt::format("{}: is not a regular file (a device or a pipe), not a {}",
                                 file.string(), what));
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open {}", file.string(), what));
  // Read until the end or one byte past the limit rather than trust the size (/proc files say 0
  // and are not), in chunks: a buffer of the limit's size (256 MiB for an OBJ) cost a page-faulted
  // memset of all of it on every read.
  std::string text;
  char chunk[1 << 16];
  while (text.size() <= max_bytes && in) {
    in.read(chunk, std::streamsize(std::min(sizeof chunk, max_bytes + 1 - text.size())));
    text.append(chunk, size_t(in.gcount()));
  }
  if (in.bad()) throw InputError(fmt::format("{}: cannot read {}", file.string(), what));
  if (text.size() > max_bytes)
    throw InputError(
        fmt::format("{}: larger than {} MiB; not a {}", file.string(), max_bytes >> 20, what));
  return text;
}

namespace {

// Rejects what yaml-cpp accepts silently: a key written twice in one mapping (yaml-cpp keeps both
// and a lookup sees one of them), a key that is a list or a mapping, and a document that aliases
// expand to more than kMaxYamlNodes nodes. `budget` counts the nodes visited, aliases included.
void check_document(const YAML::Node& node, const std::string& source, size_t& budget) {
  auto at = [&](const YAML::Node& n) {
    YAML::Mark m = n.Mark();
    return m.is_null() ? source : fmt::format("{}:{}:{}", source, m.line + 1, m.column + 1);
  };
  if (budget-- == 0)
    throw InputError(
        fmt::format("{}: the document expands to more than {} nodes (aliases of aliases?)",
                    at(node), kMaxYamlNodes));
  if (node.IsSequence()) {
    for (const auto& element : node) check_document(element, source, budget);
  } else if (node.IsMap()) {
    std::unordered_map<std::string, YAML::Mark> seen;
    for (const auto& item : node) {
      if (!item.first.IsScalar())
        throw InputError(
            fmt::format("{}: a key must be a plain name, not a list or a mapping", at(item.first)));
      auto [first, added] = seen.try_emplace(item.first.Scalar(), item.first.Mark());
      if (!added)
        throw InputError(
            fmt::format("{}: key '{}' is written twice in this mapping (first at "
                        "line {}); one of them would be ignored",
                        at(item.first), quote(first->first), first->second.line + 1));
      check_document(item.second, source, budget);
    }
  }
}

}  // namespace

void check_yaml_tree(const YAML::Node& root, const std::string& source_name) {
  size_t budget = kMaxYamlNodes;
  check_document(root, source_name, budget);
}

YamlView YamlView::load_file(const std::filesystem::path& file) {
  return parse(read_text_file(file, kMaxYamlBytes, "YAML file"), file.string());
}

YamlView YamlView::parse(const std::string& text, const std::string& source_name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    if (e.mark.is_null())
      throw InputError(fmt::format("{}: YAML syntax error: {}", source_name, e.msg));
    throw InputError(fmt::format("{}:{}:{}: YAML syntax error: {}", source_name, e.mark.line + 1,
                                 e.mark.column + 1, e.msg));
  }
  check_yaml_tree(root, source_name);
  return YamlView(root, std::make_shared<const YamlSource>(YamlSource{source_name, {}}), "");
}

YamlView::YamlView(YAML::Node node, std::shared_ptr<const YamlSource> source, std::string key_path)
    : node_(std::move(node)), source_(std::move(source)), key_path_(std::move(key_path)) {}

const YamlSource::Override* YamlView::override_here() const {
  // At or under a replaced value; or above one, in a mapping --set created (no position).
  auto under = [](const std::string& path, const std::string& prefix) {
    return path.size() > prefix.size() && path.compare(0, prefix.size(), prefix) == 0 &&
           (path[prefix.size()] == '.' || path[prefix.size()] == '[');
  };
  for (const auto& o : source_->overrides)
    if (key_path_ == o.key_path || under(key_path_, o.key_path)) return &o;
  if (node_.Mark().is_null())
    for (const auto& o : source_->overrides)
      if (key_path_.empty() || under(o.key_path, key_path_)) return &o;
  return nullptr;
}

std::string YamlView::location() const {
  if (const YamlSource::Override* o = override_here())
    return fmt::format("{} (--set {})", source_->name, quote(o->assignment, 80));
  YAML::Mark mark = node_.Mark();
  if (mark.is_null()) return source_->name;
  return fmt::format("{}:{}:{}", source_->name, mark.line + 1, mark.column + 1);
}

void YamlView::fail(const std::string& message) const {
  if (key_path_.empty()) throw InputError(fmt::format("{}: {}", location(), message));
  throw InputError(fmt::format("{}: {}: {}", location(), key_path_, message));
}

std::string YamlView::child_path(std::string_view key) const {
  return key_path_.empty() ? quote(key, 60) : key_path_ + "." + quote(key, 60);
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

double YamlView::parse_number() const {
  if (!node_.IsScalar()) fail("expected a number");
  const std::string& text = node_.Scalar();
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::out_of_range&) {
    fail(fmt::format("'{}' is beyond the range of a double", quote(text)));
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size())
    fail(fmt::format("expected a number, got '{}'", quote(text)));
  if (!std::isfinite(value)) fail(fmt::format("expected a finite number, got '{}'", quote(text)));
  return value;
}

double YamlView::as_number(double min, double max) const {
  double value = parse_number();
  if (value < min || value > max)
    fail(fmt::format("value {} is out of range [{}, {}]", quote(node_.Scalar()), min, max));
  return value;
}

int64_t YamlView::as_int(int64_t min, int64_t max) const {
  double value = parse_number();
  if (value != std::floor(value))
    fail(fmt::format("expected an integer, got '{}'", quote(node_.Scalar())));
  if (value < double(min) || value > double(max))
    fail(fmt::format("value {} is out of range [{}, {}]", quote(node_.Scalar()), min, max));
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
  fail(hint.empty() ? fmt::format("'{}' is not one of: {}", quote(value), allowed)
                    : fmt::format("'{}' is not one of: {}; did you mean '{}'?", quote(value),
                                  allowed, hint));
}

glm::vec2 YamlView::as_vec2(double min, double max) const {
  if (node_.IsScalar()) return glm::vec2(float(as_number(min, max)));
  if (!node_.IsSequence() || node_.size() != 2) fail("expected [x, y] or one number");
  return {float((*this)[size_t(0)].as_number(min, max)),
          float((*this)[size_t(1)].as_number(min, max))};
}

glm::vec3 YamlView::as_vec3(double min, double max) const {
  if (node_.IsScalar()) return glm::vec3(float(as_number(min, max)));
  if (!node_.IsSequence() || node_.size() != 3) fail("expected [x, y, z] or one number");
  return {float((*this)[size_t(0)].as_number(min, max)),
          float((*this)[size_t(1)].as_number(min, max)),
          float((*this)[size_t(2)].as_number(min, max))};
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

}  // namespace pb::config
