#include "config/key_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <map>
#include <stdexcept>

namespace pb::config {

using nlohmann::json;

ValueType string_type(std::string pattern) {
  ValueType t;
  t.pattern = std::move(pattern);
  return t;
}

ValueType number_type(double min, double max) {
  ValueType t;
  t.kind = ValueType::Kind::number;
  t.min = min, t.max = max;
  return t;
}

ValueType integer_type(int64_t min, int64_t max) {
  ValueType t = number_type(double(min), double(max));
  t.kind = ValueType::Kind::integer;
  return t;
}

ValueType boolean_type() {
  ValueType t;
  t.kind = ValueType::Kind::boolean;
  return t;
}

ValueType choice_type(std::vector<std::string> choices) {
  ValueType t;
  t.kind = ValueType::Kind::choice;
  t.choices = std::move(choices);
  return t;
}

namespace {

ValueType vector_type(size_t size, double min, double max, bool integral) {
  ValueType t = number_type(min, max);
  t.kind = ValueType::Kind::vector;
  t.size = size, t.integral = integral;
  return t;
}

}  // namespace

ValueType vec2_type(double min, double max) { return vector_type(2, min, max, false); }
ValueType vec3_type(double min, double max) { return vector_type(3, min, max, false); }
ValueType counts2_type(int64_t min, int64_t max) {
  return vector_type(2, double(min), double(max), true);
}

ValueType list_type(ValueType element, size_t min_size, bool scalar_is_list) {
  ValueType t;
  t.kind = ValueType::Kind::list;
  t.parts = {std::move(element)};
  t.size = min_size, t.scalar_is_list = scalar_is_list;
  return t;
}

ValueType tuple_type(std::vector<ValueType> elements) {
  ValueType t;
  t.kind = ValueType::Kind::tuple;
  t.parts = std::move(elements);
  return t;
}

ValueType map_of_type(ValueType value) {
  ValueType t;
  t.kind = ValueType::Kind::map_of;
  t.parts = {std::move(value)};
  return t;
}

ValueType table_type(const KeyTable& table) {
  ValueType t;
  t.kind = ValueType::Kind::table;
  t.table = &table;
  return t;
}

ValueType any_of_type(std::vector<ValueType> alternatives) {
  ValueType t;
  t.kind = ValueType::Kind::any_of;
  t.parts = std::move(alternatives);
  return t;
}

namespace {

// A reader asked a row for a kind it does not have: a bug in the reader, not bad input.
void expect_kind(const ValueType& t, ValueType::Kind kind, const char* reader) {
  if (t.kind != kind) throw std::logic_error(fmt::format("ValueType::{} on another kind", reader));
}

}  // namespace

double ValueType::number(const YamlView& v) const {
  expect_kind(*this, Kind::number, "number");
  return v.as_number(min, max);
}

int64_t ValueType::integer(const YamlView& v) const {
  expect_kind(*this, Kind::integer, "integer");
  return v.as_int(int64_t(min), int64_t(max));
}

std::string ValueType::choice(const YamlView& v) const {
  expect_kind(*this, Kind::choice, "choice");
  std::string value = v.as_string();
  if (std::find(choices.begin(), choices.end(), value) != choices.end()) return value;
  std::string hint = closest_name(value, choices);
  v.fail(fmt::format("'{}' is not one of: {}{}", quote(value), fmt::join(choices, ", "),
                     hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint)));
}

glm::vec2 ValueType::vec2(const YamlView& v) const {
  expect_kind(*this, Kind::vector, "vec2");
  return v.as_vec2(min, max);
}

glm::vec3 ValueType::vec3(const YamlView& v) const {
  expect_kind(*this, Kind::vector, "vec3");
  return v.as_vec3(min, max);
}

glm::uvec2 ValueType::counts2(const YamlView& v) const {
  expect_kind(*this, Kind::vector, "counts2");
  if (v.is_sequence()) {
    if (v.size() != 2) v.fail("expected [a, b] or one integer");
    return {uint32_t(v[size_t(0)].as_int(int64_t(min), int64_t(max))),
            uint32_t(v[size_t(1)].as_int(int64_t(min), int64_t(max)))};
  }
  auto n = uint32_t(v.as_int(int64_t(min), int64_t(max)));
  return {n, n};
}

json ValueType::schema() const {
  auto numeric = [&](bool is_integer) {
    return json{{"type", is_integer ? "integer" : "number"}, {"minimum", min}, {"maximum", max}};
  };
  switch (kind) {
    case Kind::string:
      if (pattern.empty()) return {{"type", "string"}};
      return {{"type", "string"}, {"pattern", pattern}};
    case Kind::number:
      return numeric(false);
    case Kind::integer:
      return numeric(true);
    case Kind::boolean:
      return {{"type", "boolean"}};
    case Kind::choice:
      return {{"enum", choices}};
    case Kind::vector: {
      json component = numeric(integral);
      json list = {{"type", "array"}, {"items", component}, {"minItems", size}, {"maxItems", size}};
      return {{"anyOf", {component, list}}};
    }
    case Kind::list: {
      json element = parts.at(0).schema();
      json list = {{"type", "array"}, {"items", element}};
      if (size) list["minItems"] = size;
      if (!scalar_is_list) return list;
      return {{"anyOf", {element, list}}};
    }
    case Kind::tuple: {
      json items = json::array();
      for (const auto& part : parts) items.push_back(part.schema());
      return {
          {"type", "array"}, {"prefixItems", items}, {"items", false}, {"minItems", parts.size()}};
    }
    case Kind::map_of:
      return {{"type", "object"}, {"additionalProperties", parts.at(0).schema()}};
    case Kind::table:
      return {{"$ref", "#/$defs/" + table->name}};
    case Kind::any_of: {
      json alternatives = json::array();
      for (const auto& part : parts) alternatives.push_back(part.schema());
      return {{"anyOf", alternatives}};
    }
  }
  throw std::logic_error("ValueType::schema: unknown kind");
}

const Key& KeyTable::key(std::string_view key_name) const {
  for (const auto& k : keys)
    if (k.name == key_name) return k;
  throw std::logic_error(fmt::format("key table {} has no key '{}'", name, key_name));
}

std::vector<std::string> KeyTable::names() const {
  std::vector<std::string> out;
  for (const auto& k : keys) out.push_back(k.name);
  return out;
}

void KeyTable::allow(const YamlView& v) const { v.allow_keys(names()); }

std::string KeyTable::tag() const {
  const Key& type = key("type");
  if (type.type.kind != ValueType::Kind::choice || type.type.choices.size() != 1)
    throw std::logic_error(fmt::format("key table {}: 'type' is not one tag", name));
  return type.type.choices[0];
}

namespace {

// The row's default when the key is absent; the key's value otherwise.
template <class T, class Read>
T read_key(const KeyTable& table, const YamlView& v, std::string_view key_name, Read read) {
  const Key& k = table.key(key_name);
  if (k.required || !v.has(key_name)) {
    if (k.required) return read(k.type, v[key_name]);  // absent: "missing required key"
    if (k.default_value.is_null())
      throw std::logic_error(fmt::format("{}.{} has no default", table.name, key_name));
    return k.default_value.get<T>();
  }
  return read(k.type, v[key_name]);
}

}  // namespace

double KeyTable::number(const YamlView& v, std::string_view key_name) const {
  return read_key<double>(*this, v, key_name,
                          [](const ValueType& t, const YamlView& x) { return t.number(x); });
}

int64_t KeyTable::integer(const YamlView& v, std::string_view key_name) const {
  return read_key<int64_t>(*this, v, key_name,
                           [](const ValueType& t, const YamlView& x) { return t.integer(x); });
}

bool KeyTable::boolean(const YamlView& v, std::string_view key_name) const {
  return read_key<bool>(*this, v, key_name, [](const ValueType& t, const YamlView& x) {
    expect_kind(t, ValueType::Kind::boolean, "boolean");
    return x.as_bool();
  });
}

std::string KeyTable::string(const YamlView& v, std::string_view key_name) const {
  return read_key<std::string>(*this, v, key_name, [](const ValueType& t, const YamlView& x) {
    if (t.kind == ValueType::Kind::choice) return t.choice(x);
    expect_kind(t, ValueType::Kind::string, "string");
    return x.as_string();
  });
}

namespace {

// A vector default: one number for every component, or the components.
template <class Vec>
Vec vector_default(const nlohmann::json& value) {
  if (value.is_number()) return Vec(value.get<float>());
  Vec out;
  for (int i = 0; i < Vec::length(); ++i) out[i] = value.at(size_t(i)).get<float>();
  return out;
}

}  // namespace

glm::vec2 KeyTable::vec2(const YamlView& v, std::string_view key_name) const {
  const Key& k = key(key_name);
  if (!k.required && !v.has(key_name)) return vector_default<glm::vec2>(k.default_value);
  return k.type.vec2(v[key_name]);
}

glm::vec3 KeyTable::vec3(const YamlView& v, std::string_view key_name) const {
  const Key& k = key(key_name);
  if (!k.required && !v.has(key_name)) return vector_default<glm::vec3>(k.default_value);
  return k.type.vec3(v[key_name]);
}

double KeyTable::number_or(const YamlView& v, std::string_view key_name, double fallback) const {
  if (!v.has(key_name)) return fallback;
  return key(key_name).type.number(v[key_name]);
}

const KeyTable& select_variant(const YamlView& v, const std::vector<const KeyTable*>& variants) {
  std::vector<std::string> tags;
  for (const KeyTable* t : variants) tags.push_back(t->tag());
  std::string tag = choice_type(tags).choice(v["type"]);
  const KeyTable& table = **std::find_if(variants.begin(), variants.end(),
                                         [&](const KeyTable* t) { return t->tag() == tag; });
  table.allow(v);
  return table;
}

ValueType variants_type(const std::vector<const KeyTable*>& variants) {
  std::vector<ValueType> alternatives;
  for (const KeyTable* t : variants) alternatives.push_back(table_type(*t));
  return any_of_type(std::move(alternatives));
}

namespace {

json table_schema(const KeyTable& table) {
  json properties = json::object();
  json required = json::array();
  for (const auto& k : table.keys) {
    json property = k.type.schema();
    if (!k.doc.empty()) property["description"] = k.doc;
    if (!k.default_value.is_null()) property["default"] = k.default_value;
    properties[k.name] = property;
    if (k.required) required.push_back(k.name);
  }
  json out = {{"type", "object"}, {"properties", properties}, {"additionalProperties", false}};
  if (!table.doc.empty()) out["description"] = table.doc;
  if (!required.empty()) out["required"] = required;
  return out;
}

// Every table reachable from `type`, by name (a name twice for two tables is a bug).
void collect_tables(const ValueType& type, std::map<std::string, const KeyTable*>& found) {
  if (type.table) {
    auto [it, added] = found.try_emplace(type.table->name, type.table);
    if (!added && it->second != type.table)
      throw std::logic_error("two key tables are named " + type.table->name);
    if (added)
      for (const auto& k : type.table->keys) collect_tables(k.type, found);
  }
  for (const auto& part : type.parts) collect_tables(part, found);
}

}  // namespace

json schema_document(const KeyTable& root, const json& extra_defs) {
  std::map<std::string, const KeyTable*> tables;
  collect_tables(table_type(root), tables);
  json defs = json::object();
  for (const auto& [name, table] : tables) defs[name] = table_schema(*table);
  for (const auto& [name, def] : extra_defs.items()) defs[name] = def;
  json document = table_schema(root);
  document["$schema"] = "https://json-schema.org/draft/2020-12/schema";
  document["title"] = root.doc;
  document["$defs"] = defs;
  return document;
}

}  // namespace pb::config
