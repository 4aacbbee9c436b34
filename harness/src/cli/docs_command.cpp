// `photonbench docs technique NAME [--write README.md]`: a technique's Parameters, Counters and
// Budget knobs as markdown tables, printed from its descriptor, so that its README's tables are
// generated, never copied by hand. --write replaces the tables of a README between its marker
// comments, one pair per table:
//
//   <!-- generated: parameters -->        (also "counters" and "budget knobs")
//   ...the table, rewritten...
//   <!-- end generated -->
//
// tests/e2e/readme_tables.sh regenerates every technique README this way and fails on a difference.
#include <fmt/format.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli/command.h"
#include "photonbench/error.h"
#include "plan/plugins.h"

namespace {

constexpr const char* kEndMarker = "<!-- end generated -->";

// A table cell: a '|' in the text would end the cell.
std::string cell(const char* text) {
  std::string out;
  for (const char* c = text ? text : ""; *c; ++c) {
    if (*c == '|') out += '\\';
    out += *c;
  }
  return out;
}

std::string parameters_table(const pb_technique_descriptor& d) {
  if (d.param_count == 0) return "None: the descriptor declares no parameter.\n";
  std::string out = "| name | type | default | range | unit | doc |\n|---|---|---|---|---|---|\n";
  for (uint32_t i = 0; i < d.param_count; ++i) {
    const pb_param_spec& p = d.params[i];
    std::string range;
    if (p.type == PB_PARAM_ENUM) {
      std::istringstream choices(p.choices ? p.choices : "");
      for (std::string choice; std::getline(choices, choice, '|');)
        range += (range.empty() ? "" : ", ") + choice;
    } else if (p.type != PB_PARAM_BOOL) {
      range = p.type == PB_PARAM_INT
                  ? fmt::format("[{}, {}]", int64_t(p.min_value), int64_t(p.max_value))
                  : fmt::format("[{}, {}]", p.min_value, p.max_value);
    }
    out +=
        fmt::format("| `{}` | {} | {} | {} | {} | {} |\n", p.name, pb::run::param_type_name(p),
                    cell(pb::run::param_default_text(p).c_str()), range, cell(p.unit), cell(p.doc));
  }
  return out;
}

std::string counters_table(const pb_technique_descriptor& d) {
  if (d.counter_count == 0) return "None: the descriptor declares no counter.\n";
  std::string out = "| counter | kind | unit | meaning |\n|---|---|---|---|\n";
  std::set<std::string> listed;  // a counter two parts of a technique declare, once
  for (uint32_t i = 0; i < d.counter_count; ++i) {
    const pb_counter_spec& c = d.counters[i];
    if (!listed.insert(c.name).second) continue;
    out += fmt::format("| `{}` | {} | {} | {} |\n", c.name, pb::run::counter_kind_text(c.kind),
                       cell(c.unit), cell(c.doc));
  }
  return out;
}

std::string budget_table(const pb_technique_descriptor& d) {
  if (d.budget_count == 0) return "None: the descriptor declares no budget knob.\n";
  std::string out = "| knob | cost as it grows | error as it grows | scale |\n|---|---|---|---|\n";
  for (uint32_t i = 0; i < d.budget_count; ++i) {
    const pb_budget_knob& k = d.budget[i];
    out +=
        fmt::format("| `{}` | {} | {} | {} |\n", k.param, pb::run::budget_direction_text(k.cost),
                    pb::run::budget_direction_text(k.error), pb::run::budget_scale_text(k.scale));
  }
  return out;
}

struct GeneratedTable {
  const char* name;  // the marker's: <!-- generated: NAME -->
  const char* heading;
  std::string text;
};

std::array<GeneratedTable, 3> tables(const pb_technique_descriptor& d) {
  return {GeneratedTable{"parameters", "Parameters", parameters_table(d)},
          GeneratedTable{"counters", "Counters", counters_table(d)},
          GeneratedTable{"budget knobs", "Budget knobs", budget_table(d)}};
}

// `text` with each table between its markers replaced; a marker missing, doubled or unclosed is an
// error naming the file and line.
std::string rewrite(const std::string& text, const std::filesystem::path& file,
                    const std::array<GeneratedTable, 3>& generated) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::string out;
  std::set<std::string> written;
  for (size_t i = 0; i < lines.size(); ++i) {
    out += lines[i] + "\n";
    const GeneratedTable* table = nullptr;
    for (const auto& t : generated)
      if (lines[i] == fmt::format("<!-- generated: {} -->", t.name)) table = &t;
    if (!table) continue;
    if (!written.insert(table->name).second)
      throw pb::InputError(
          fmt::format("{}:{}: a second '{}' marker", file.string(), i + 1, lines[i]));
    size_t end = i + 1;
    while (end < lines.size() && lines[end] != kEndMarker) ++end;
    if (end == lines.size())
      throw pb::InputError(fmt::format("{}:{}: '{}' has no '{}' after it", file.string(), i + 1,
                                       lines[i], kEndMarker));
    out += table->text + kEndMarker + "\n";
    i = end;
  }
  for (const auto& t : generated)
    if (!written.count(t.name))
      throw pb::InputError(fmt::format(
          "{}: no '<!-- generated: {} -->' marker (put the marker and '{}' around its {} table)",
          file.string(), t.name, kEndMarker, t.heading));
  return out;
}

struct DocsOptions {
  std::string what, name, write;
  std::vector<std::string> plugin_dirs;
};

int run_docs(const DocsOptions& options) {
  std::vector<std::filesystem::path> dirs(options.plugin_dirs.begin(), options.plugin_dirs.end());
  pb::run::PluginRegistry plugins(dirs);
  const pb::run::Plugin* plugin = plugins.find(options.name);
  if (!plugin)
    throw pb::InputError(
        fmt::format("no technique '{}' (photonbench list techniques)", options.name));
  if (!plugin->loaded())
    throw pb::Error(
        fmt::format("technique '{}' does not load: {}", options.name, plugin->load_error));
  const auto generated = tables(*plugin->descriptor);
  if (options.write.empty()) {
    for (const auto& t : generated) std::printf("## %s\n\n%s\n", t.heading, t.text.c_str());
    return 0;
  }
  const std::filesystem::path file = options.write;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw pb::InputError(fmt::format("{}: cannot read", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  const std::string rewritten = rewrite(text.str(), file, generated);
  if (rewritten != text.str()) {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << rewritten;
    if (!out) throw pb::Error(fmt::format("{}: cannot write", file.string()));
  }
  return 0;
}

void add_docs(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<DocsOptions>();
  auto* cmd = app.add_subcommand(
      "docs", "a technique's Parameters, Counters and Budget knobs tables (markdown)");
  cmd->add_option("what", options->what, "technique")
      ->required()
      ->check(CLI::IsMember({"technique"}));
  cmd->add_option("name", options->name, "the technique's name")->required();
  cmd->add_option("--plugin-dir", options->plugin_dirs, "also look for technique plugins here");
  cmd->add_option("--write", options->write,
                  "rewrite the tables of this README between its marker comments");
  cmd->callback([options, &exit_code] { exit_code = run_docs(*options); });
}

pb::cli::CommandRegistration docs_registration{"docs", add_docs};

}  // namespace
