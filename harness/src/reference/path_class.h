// The path classes a reference is split into, and the light path expressions that name them: the
// vocabulary of the reference renderer, of the techniques' declared classes (plugin.h's path_class)
// and of the scores. Below the renderer, so that the path-space rule (path_space.h) and the plan
// can use the classes without the renderer.
//
// Path classes (light path expressions read from the camera, S any non-diffuse interaction
// including rough GGX, D diffuse or emissive, L an emitter). They partition all paths, so
//   direct + indirect + caustics + indirect_caustics + specular = combined:
//   direct             C L | C D L               emitters seen directly and direct light
//   indirect           C D (D|S)* D (D|S)* L     first hit diffuse, at least one more diffuse
//   vertex
//                                                (indirect diffuse; includes caustics seen via
//                                                diffuse interreflection, C D D S+ L)
//   caustics           C D S+ L                  caustics seen directly
//   indirect_caustics  C S+ D S+ L               caustics seen through specular surfaces
//   specular           C S+ L | C S+ D L | C S+ D (D|S)* D (D|S)* L
//                                                the rest of what is first seen through a specular
//                                                surface (reflections and refractions of emitters,
//                                                of direct and of indirect light)
// (caustics + indirect_caustics is the caustic class C S* D S+ L.)
//
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

namespace pb::trace {

enum class PathClass : uint8_t {
  direct,
  indirect,
  caustics,
  indirect_caustics,
  specular,
  combined
};
inline constexpr int kPathClassCount = 6;
inline constexpr uint32_t kAllPathClasses = (1u << kPathClassCount) - 1u;
inline constexpr uint32_t class_bit(PathClass c) { return 1u << uint32_t(c); }

std::string_view path_class_name(PathClass c);        // "direct", "indirect_caustics", ...
std::string_view path_class_expression(PathClass c);  // "C D S+ L", ...
std::optional<PathClass> parse_path_class(std::string_view name);
// The class a technique declares (plugin.h's path_class): a class name ("caustics") or its light
// path expression ("C D S+ L", spaces ignored).
std::optional<PathClass> reference_class_of(std::string_view name_or_expression);
std::vector<PathClass> all_path_classes();

}  // namespace pb::trace
