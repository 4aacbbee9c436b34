#include "reference/path_class.h"

#include <algorithm>
#include <string>

namespace pb::trace {
namespace {

struct ClassInfo {
  PathClass id;
  std::string_view name, expression;
};
constexpr ClassInfo kClassInfo[kPathClassCount] = {
    {PathClass::direct, "direct", "C L | C D L"},
    {PathClass::indirect, "indirect", "C D (D|S)* D (D|S)* L"},
    {PathClass::caustics, "caustics", "C D S+ L"},
    {PathClass::indirect_caustics, "indirect_caustics", "C S+ D S+ L"},
    {PathClass::specular, "specular", "C S+ L | C S+ D L | C S+ D (D|S)* D (D|S)* L"},
    {PathClass::combined, "combined", "C (D|S)* L"},
};

}  // namespace

std::string_view path_class_name(PathClass c) { return kClassInfo[int(c)].name; }
std::string_view path_class_expression(PathClass c) { return kClassInfo[int(c)].expression; }
std::optional<PathClass> parse_path_class(std::string_view name) {
  for (const auto& info : kClassInfo)
    if (info.name == name) return info.id;
  return std::nullopt;
}

std::optional<PathClass> reference_class_of(std::string_view name_or_expression) {
  auto squeeze = [](std::string_view text) {
    std::string s(text);
    s.erase(std::remove(s.begin(), s.end(), ' '), s.end());
    return s;
  };
  if (auto by_name = parse_path_class(name_or_expression)) return by_name;
  for (PathClass c : all_path_classes())
    if (squeeze(path_class_expression(c)) == squeeze(name_or_expression)) return c;
  return std::nullopt;
}
std::vector<PathClass> all_path_classes() {
  std::vector<PathClass> out;
  for (const auto& info : kClassInfo) out.push_back(info.id);
  return out;
}

}  // namespace pb::trace
