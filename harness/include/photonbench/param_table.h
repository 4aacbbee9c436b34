// One declaration per technique parameter: its name, default, range, unit and doc, bound to the
// field of a typed params struct it fills. The declaration gives the descriptor's C row
// (pb_param_spec, whose type follows from the field's C++ type) and reads a cell's values into the
// struct, so a parameter costs two edits, its declaration and its use:
//
//   enum class Reuse : uint32_t { none, naive, error_based };  // enumerator i: the i-th choice
//   struct FilterParams {
//     float alpha;
//     uint32_t iterations;
//     bool spatial;
//     Reuse reuse;
//   };
//   constexpr auto kFilterParams = pb::params(
//       pb::param("temporal_alpha", &FilterParams::alpha, 0.95, {0, 1}, "", "blend weight"),
//       pb::param("iterations", &FilterParams::iterations, 4, {1, 8}, "passes", "a-trous passes"),
//       pb::param("spatial", &FilterParams::spatial, true, "the spatial filter"),
//       pb::param("reuse", &FilterParams::reuse, Reuse::error_based, "none|naive|error_based",
//                 "which paths are kept"));
//   PB_EXPORT_TECHNIQUE(Mine, "mine", "indirect", "...", kFilterParams.rows)
//   ... in setup: const FilterParams filter = kFilterParams.read(params);
//
// A row several structs share (the toolkit's `photons`) is declared once, bound to its owner's
// field, and bound to another struct's field with pb::bind(row, &Other::field); a field the params
// struct inherits is named pb::base_field<Params>(&Base::field). Rows of several
// tables make one schema with pb::join_rows (or pb::merge_rows, where tables share a row).
// Defaults live in the declaration: kTable.defaults() is the struct with every default, and a
// struct that keeps member initialisers checks them with
// static_assert(kTable.member_defaults_match()).
//
// Everything here is constexpr: a default outside its range, a row bound to a field of another
// type, an enum default with no choice or two rows of one name fail to compile.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <tuple>
#include <type_traits>

#include "photonbench/plugin.h"

namespace pb {

// A numeric parameter's closed range [min, max].
struct Range {
  double min = 0, max = 0;
};

namespace detail {

template <class F>
constexpr bool is_number_v = std::is_arithmetic_v<F> && !std::is_same_v<F, bool>;

// The C type of a row whose value reads into F.
template <class F>
constexpr pb_param_type param_type_of() {
  if constexpr (std::is_same_v<F, bool>)
    return PB_PARAM_BOOL;
  else if constexpr (std::is_enum_v<F>)
    return PB_PARAM_ENUM;
  else if constexpr (std::is_integral_v<F>)
    return PB_PARAM_INT;
  else
    return PB_PARAM_FLOAT;
}

// The names of "a|b|c": 3.
constexpr size_t choice_count(std::string_view choices) {
  size_t n = 1;
  for (char c : choices) n += c == '|';
  return n;
}

// Throwing here in a constant expression is a compile error naming this message.
constexpr void require(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

template <class F>
constexpr void check_row(const pb_param_spec& row) {
  require(row.name != nullptr && *row.name != '\0', "a parameter needs a name");
  require(row.type == param_type_of<F>(), "the row's type is not the field's");
  require(row.doc != nullptr, "a parameter needs a doc");
  if constexpr (is_number_v<F>) {
    require(row.min_value <= row.default_value && row.default_value <= row.max_value,
            "the default lies outside the range");
    if constexpr (std::is_integral_v<F>) {
      require(double(std::numeric_limits<F>::lowest()) <= row.min_value &&
                  row.max_value <= double(std::numeric_limits<F>::max()),
              "the range does not fit the field's integer type");
      require(row.default_value == double(int64_t(row.default_value)),
              "an integer parameter's default is not whole");
    }
  } else if constexpr (std::is_enum_v<F>) {
    require(row.choices != nullptr, "an enum parameter needs choices");
    require(row.default_value >= 0 && row.default_value < double(choice_count(row.choices)),
            "the default enumerator has no choice");
  }
}

}  // namespace detail

// A row bound to the field of S it fills.
template <class S, class F>
struct Param {
  pb_param_spec row;
  F S::*field;

  // The cell's value of this row into `out` (the harness checked its type and range).
  void read_into(S& out, const Params& values) const {
    if constexpr (std::is_same_v<F, bool>)
      out.*field = values.flag(row.name);
    else if constexpr (std::is_enum_v<F>)
      out.*field = values.choice<F>(row.name, row.choices);
    else if constexpr (std::is_integral_v<F>)
      out.*field = F(values.integer(row.name));
    else
      out.*field = F(values.number(row.name));
  }
  constexpr F default_value() const {
    if constexpr (std::is_same_v<F, bool>)
      return row.default_value != 0;
    else if constexpr (std::is_enum_v<F>)
      return F(std::underlying_type_t<F>(row.default_value));
    else
      return F(row.default_value);
  }
};

// ---- Rows. Their C type follows from the field's C++ type: an integer is PB_PARAM_INT, a
// floating-point number PB_PARAM_FLOAT, bool PB_PARAM_BOOL and an enumeration PB_PARAM_ENUM
// (enumerator i is the i-th name of `choices`, so the enum counts 0, 1, 2, ...).

template <class F>
requires detail::is_number_v<F>
constexpr pb_param_spec row(const char* name, double default_value, Range range, const char* unit,
                            const char* doc) {
  pb_param_spec out{
      name, detail::param_type_of<F>(), default_value, range.min, range.max, nullptr, unit, doc};
  detail::check_row<F>(out);
  return out;
}

template <class F>
requires std::is_same_v<F, bool>
constexpr pb_param_spec row(const char* name, bool default_value, const char* doc) {
  pb_param_spec out{name, PB_PARAM_BOOL, default_value ? 1.0 : 0.0, 0, 1, nullptr, "", doc};
  detail::check_row<F>(out);
  return out;
}

template <class F>
requires std::is_enum_v<F>
constexpr pb_param_spec row(const char* name, F default_value, const char* choices,
                            const char* doc) {
  const double last = double(detail::choice_count(choices ? choices : "") - 1);
  const double index = double(std::underlying_type_t<F>(default_value));
  pb_param_spec out{name, PB_PARAM_ENUM, index, 0, last, choices, "", doc};
  detail::check_row<F>(out);
  return out;
}

// ---- Bound rows: a declaration and the field it fills.

template <class S, class F>
constexpr Param<S, F> bind(const pb_param_spec& row, F S::*field) {
  detail::check_row<F>(row);
  return {row, field};
}

template <class S, class F>
requires detail::is_number_v<F>
constexpr Param<S, F> param(const char* name, F S::*field, double default_value, Range range,
                            const char* unit, const char* doc) {
  return {row<F>(name, default_value, range, unit, doc), field};
}

template <class S>
constexpr Param<S, bool> param(const char* name, bool S::*field, bool default_value,
                               const char* doc) {
  return {row<bool>(name, default_value, doc), field};
}

template <class S, class F>
requires std::is_enum_v<F>
constexpr Param<S, F> param(const char* name, F S::*field, std::type_identity_t<F> default_value,
                            const char* choices, const char* doc) {
  return {row<F>(name, default_value, choices, doc), field};
}

// A field of a base struct as a field of Derived, the struct a table reads into: a row of a
// technique's params struct that fills a field its parts declare (a core struct the unit tests
// build whole, the toolkit's PhotonParams), e.g.
//   struct AapsParams : aaps::FeedbackParams { ... };
//   pb::param("density_min", pb::base_field<AapsParams>(&aaps::FeedbackParams::density_min), ...)
template <class Derived, class Base, class F>
requires std::is_base_of_v<Base, Derived>
constexpr F Derived::*base_field(F Base::*field) { return field; }

// A schema's rows as one C array (`rows`), which PB_EXPORT_TECHNIQUE takes as its `params`.
template <size_t N>
struct ParamRows {
  pb_param_spec rows[N];

  constexpr size_t size() const { return N; }
  // The row of `name`; in a constant expression, a name no row has fails to compile.
  constexpr const pb_param_spec& row(std::string_view name) const {
    for (const pb_param_spec& r : rows)
      if (name == r.name) return r;
    throw std::logic_error("no parameter row of this name");
  }
};

// The rows of S's parameters, each bound to the field it fills.
template <class S, class... F>
struct ParamTable : ParamRows<sizeof...(F)> {
  std::tuple<Param<S, F>...> params;

  constexpr explicit ParamTable(Param<S, F>... bound)
      : ParamRows<sizeof...(F)>{{bound.row...}}, params(bound...) {
    for (size_t i = 0; i < sizeof...(F); ++i)
      for (size_t j = 0; j < i; ++j)
        detail::require(std::string_view(this->rows[i].name) != this->rows[j].name,
                        "two parameters of one name");
  }

  // This table with the row of `replacement`'s name replaced by it (a technique's own default,
  // range or doc for a shared row, e.g. through pb::toolkit::with_range); its type must stay.
  constexpr ParamTable with_row(const pb_param_spec& replacement) const {
    ParamTable out = *this;
    bool found = false;
    for (pb_param_spec& r : out.rows)
      if (std::string_view(r.name) == replacement.name) r = replacement, found = true;
    detail::require(found, "no parameter row of this name");
    std::apply(
        [&](auto&... p) {
          ((std::string_view(p.row.name) == replacement.name
                ? (p = pb::bind(replacement, p.field), 0)
                : 0),
           ...);
        },
        out.params);
    return out;
  }

  // Every bound field from the cell's values; a row the technique's schema lacks throws pb::Error.
  S read(const Params& values) const {
    S out = defaults();
    std::apply([&](const auto&... p) { (p.read_into(out, values), ...); }, params);
    return out;
  }
  // Every bound field at its declared default.
  constexpr S defaults() const {
    S out{};
    std::apply([&](const auto&... p) { ((out.*(p.field) = p.default_value()), ...); }, params);
    return out;
  }
  // Whether S's member initialisers equal the declared defaults (for a static_assert).
  constexpr bool member_defaults_match() const {
    const S initialised{};
    return std::apply(
        [&](const auto&... p) { return ((initialised.*(p.field) == p.default_value()) && ...); },
        params);
  }
};

template <class S, class... F>
constexpr ParamTable<S, F...> params(Param<S, F>... bound) {
  return ParamTable<S, F...>(bound...);
}

namespace detail {

constexpr bool same_text(const char* a, const char* b) {
  return (a == nullptr || b == nullptr) ? a == b : std::string_view(a) == b;
}

constexpr bool same_row(const pb_param_spec& a, const pb_param_spec& b) {
  return same_text(a.name, b.name) && a.type == b.type && a.default_value == b.default_value &&
         a.min_value == b.min_value && a.max_value == b.max_value &&
         same_text(a.choices, b.choices) && same_text(a.unit, b.unit) && same_text(a.doc, b.doc);
}

// The rows of `all` but those an earlier row of the same name has; such a pair must be the same
// row (one declaration bound in two tables), else this fails to compile.
template <size_t N>
constexpr size_t distinct_row_count(const ParamRows<N>& all) {
  size_t count = 0;
  for (size_t i = 0; i < N; ++i) {
    bool first = true;
    for (size_t j = 0; j < i && first; ++j)
      if (std::string_view(all.rows[i].name) == all.rows[j].name) {
        require(same_row(all.rows[i], all.rows[j]), "two different parameters of one name");
        first = false;
      }
    count += first;
  }
  return count;
}

template <size_t... N>
constexpr ParamRows<(N + ...)> concatenate(const ParamRows<N>&... parts) {
  ParamRows<(N + ...)> out{};
  size_t at = 0;
  ((std::copy(parts.rows, parts.rows + N, out.rows + at), at += N), ...);
  return out;
}

}  // namespace detail

// Several tables' (or row arrays') rows as one schema, in order; two rows of one name fail to
// compile.
template <size_t... N>
constexpr ParamRows<(N + ...)> join_rows(const ParamRows<N>&... parts) {
  ParamRows<(N + ...)> out = detail::concatenate(parts...);
  for (size_t i = 0; i < out.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      detail::require(std::string_view(out.rows[i].name) != out.rows[j].name,
                      "two parameters of one name");
  return out;
}

// The rows of several tables as one schema, in order, a row that two of them bind (the same
// declaration) once: the schema of a technique whose parts share rows (path verification's three
// splatters). The tables are constexpr objects of static storage (namespace scope or static
// members).
template <const auto&... parts>
constexpr auto merge_rows() {
  constexpr auto all = detail::concatenate(parts...);
  constexpr size_t n = detail::distinct_row_count(all);
  ParamRows<n> out{};
  size_t at = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    bool first = true;
    for (size_t j = 0; j < i; ++j)
      first = first && std::string_view(all.rows[i].name) != all.rows[j].name;
    if (first) out.rows[at++] = all.rows[i];
  }
  return out;
}

// ---- Counters, declared once in one table that is also the descriptor's array (`specs`), and
// counted by name: pb::count(ctx, kCounters["paths_kept"], n), a name the table lacks failing to
// compile.
//
//   constexpr auto kCounters = pb::counters({
//       {"paths_kept", PB_COUNTER_WORK, "paths", "paths with no segment re-traced"},
//       {"bytes_photon_map", PB_COUNTER_SIZE, "bytes", "the photon map"},
//   });
//   PB_EXPORT_TECHNIQUE(..., .counters = kCounters.specs)
template <size_t N>
struct CounterTable {
  pb_counter_spec specs[N];

  constexpr size_t size() const { return N; }
  consteval const pb_counter_spec& operator[](std::string_view name) const {
    for (const pb_counter_spec& c : specs)
      if (name == c.name) return c;
    throw std::logic_error("no counter of this name");
  }
};

template <size_t N>
constexpr CounterTable<N> counters(const pb_counter_spec (&specs)[N]) {
  CounterTable<N> out{};
  for (size_t i = 0; i < N; ++i) {
    detail::require(specs[i].name != nullptr && specs[i].doc != nullptr,
                    "a counter needs a name and a doc");
    for (size_t j = 0; j < i; ++j)
      detail::require(std::string_view(specs[i].name) != specs[j].name, "two counters of one name");
    out.specs[i] = specs[i];
  }
  return out;
}

}  // namespace pb
