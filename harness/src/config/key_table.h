// One definition per YAML mapping of the config and scene formats: its keys, each with a type, a
// finite range, a default and a one-line doc. The readers (config.cpp, scene/scene_loader.cpp)
// allow, range-check and default every key through these tables, and `photonbench schema` prints
// the same tables as JSON Schema, so what an editor checks and what `validate` checks cannot drift
// apart. What a table cannot say (far beyond near, a camera off its target, a scene file that
// exists) stays in the readers' code as a semantic check.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "config/yaml_view.h"

namespace pb::config {

struct KeyTable;

// The shape of one YAML value. Numbers carry their finite range; a vector is [x, y] or [x, y, z]
// or one number for every component (YamlView::as_vec3); a list may also be written as its one
// element (YamlView::elements); a tuple is a fixed-length list such as a keyframe [t, value]; a
// map_of is a mapping of names the file chooses (materials) to values of one type.
struct ValueType {
  enum class Kind {
    string,
    number,
    integer,
    boolean,
    choice,
    vector,
    list,
    tuple,
    map_of,
    table,
    any_of
  };
  Kind kind = Kind::string;
  double min = 0, max = 0;           // number, integer, vector (each component)
  size_t size = 0;                   // vector: components; list: the fewest elements
  bool integral = false;             // vector: integer components
  bool scalar_is_list = false;       // list: one element may stand for the list
  std::vector<std::string> choices;  // choice
  std::string pattern;  // string: a regular expression (ECMAScript) the whole value matches
  // list: {element}; tuple: the elements; map_of: {value}; any_of: the alternatives
  std::vector<ValueType> parts;
  const KeyTable* table = nullptr;  // table

  // Readers: the value checked against this type (a pb::InputError at the value otherwise).
  double number(const YamlView& v) const;
  int64_t integer(const YamlView& v) const;
  std::string choice(const YamlView& v) const;
  glm::vec2 vec2(const YamlView& v) const;
  glm::vec3 vec3(const YamlView& v) const;
  glm::uvec2 counts2(const YamlView& v) const;  // an integral vector of 2; one n means [n, n]

  nlohmann::json schema() const;
};

ValueType string_type(std::string pattern = "");
ValueType number_type(double min, double max);
ValueType integer_type(int64_t min, int64_t max);
ValueType boolean_type();
ValueType choice_type(std::vector<std::string> choices);
ValueType vec2_type(double min, double max);
ValueType vec3_type(double min, double max);
ValueType counts2_type(int64_t min, int64_t max);
ValueType list_type(ValueType element, size_t min_size, bool scalar_is_list);
ValueType tuple_type(std::vector<ValueType> elements);
ValueType map_of_type(ValueType value);
ValueType table_type(const KeyTable& table);
ValueType any_of_type(std::vector<ValueType> alternatives);

struct Key {
  Key(std::string key_name, ValueType key_type, bool is_required = false,
      nlohmann::json default_json = nullptr, std::string key_doc = "")
      : name(std::move(key_name)),
        type(std::move(key_type)),
        required(is_required),
        default_value(std::move(default_json)),
        doc(std::move(key_doc)) {}
  std::string name;
  ValueType type;
  bool required;
  // The value an absent key takes (a number, a vector's components, a bool or a string), or null
  // when the reader computes it (the doc says how) or the key is required.
  nlohmann::json default_value;
  std::string doc;
};

// The keys of one mapping. `name` is its JSON Schema $defs name ("scene.light.spot").
struct KeyTable {
  std::string name;
  std::string doc;
  std::vector<Key> keys;

  const Key& key(std::string_view key_name) const;  // std::logic_error for a name not in the table
  std::vector<std::string> names() const;
  // The mapping holds only the table's keys (YamlView::allow_keys: a misspelt one is an error
  // suggesting the closest name).
  void allow(const YamlView& v) const;
  // A variant table ("scene.light.point") has a required `type` key of one choice: its tag.
  std::string tag() const;

  // Each value checked against its row; an absent key takes the row's default (a required key
  // that is absent is an error at the mapping).
  double number(const YamlView& v, std::string_view key_name) const;
  int64_t integer(const YamlView& v, std::string_view key_name) const;
  bool boolean(const YamlView& v, std::string_view key_name) const;
  std::string string(const YamlView& v, std::string_view key_name) const;
  glm::vec2 vec2(const YamlView& v, std::string_view key_name) const;
  glm::vec3 vec3(const YamlView& v, std::string_view key_name) const;
  // As number(), for a row whose default the reader computes.
  double number_or(const YamlView& v, std::string_view key_name, double fallback) const;
};

// The variant of a tagged mapping ({type: spot, ...}): v["type"] checked against the variants'
// tags, the variant's keys allowed. Returns the variant's table.
const KeyTable& select_variant(const YamlView& v, const std::vector<const KeyTable*>& variants);
// The schema type of such a mapping: any of the variants.
ValueType variants_type(const std::vector<const KeyTable*>& variants);

// A JSON Schema (draft 2020-12) document whose root is `root`, every table reachable from it in
// $defs under its name. `extra_defs` are added to $defs and replace a table's def of the same name:
// what the loaded plugins know (technique names, parameter schemas) is not in any static table.
nlohmann::json schema_document(const KeyTable& root,
                               const nlohmann::json& extra_defs = nlohmann::json::object());

// The config format (config.cpp) and the scene format (scene/scene_loader.cpp): what their
// readers check and `photonbench schema` prints.
const KeyTable& config_table();

}  // namespace pb::config

namespace pb::scene {
const config::KeyTable& scene_table();
}  // namespace pb::scene
