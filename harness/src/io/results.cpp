#include "io/results.h"

#include <fmt/format.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "photonbench/error.h"

namespace pb::io {

void write_text_atomic(const std::filesystem::path& file, const std::string& text) {
  std::filesystem::path tmp =
      file.parent_path() / (".tmp-" + std::to_string(::getpid()) + "-" + file.filename().string());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(fmt::format("{}: cannot write", file.string()));
    out << text;
    out.flush();
    if (!out) throw Error(fmt::format("{}: write failed", file.string()));
  }
  std::filesystem::rename(tmp, file);
}

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot read", file.string()));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string csv_escape(const std::string& field) {
  if (field.find_first_of(",\"\n\r") == std::string::npos) return field;
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string csv_row(const std::vector<std::string>& fields) {
  std::string line;
  for (size_t i = 0; i < fields.size(); ++i) {
    if (i) line += ',';
    line += csv_escape(fields[i]);
  }
  return line + "\n";
}

CsvAppender::CsvAppender(const std::filesystem::path& file,
                         const std::vector<std::string>& header) {
  file_ = std::fopen(file.c_str(), "w");
  if (!file_) throw Error(fmt::format("{}: cannot write", file.string()));
  row(header);
}

CsvAppender::~CsvAppender() {
  if (file_) std::fclose(file_);
}

void CsvAppender::row(const std::vector<std::string>& fields) {
  std::string line = csv_row(fields);
  std::fwrite(line.data(), 1, line.size(), file_);
  std::fflush(file_);
}

std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& file) {
  std::string text = read_text(file);
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> row;
  std::string field;
  bool quoted = false, any = false;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"')
        field += '"', ++i;
      else if (c == '"')
        quoted = false;
      else
        field += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      row.push_back(field), field.clear();
    } else if (c == '\n') {
      row.push_back(field), field.clear();
      rows.push_back(row), row.clear();
      any = false;
      continue;
    } else if (c != '\r') {
      field += c;
    }
    any = true;
  }
  if (any) row.push_back(field), rows.push_back(row);
  return rows;
}

}  // namespace pb::io
