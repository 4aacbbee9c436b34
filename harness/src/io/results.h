// Writing results: text files written atomically (temporary name, then rename) and CSV rows with
// the quoting spreadsheets and pandas expect. Schema: docs/architecture.md, "Results".
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace pb::io {

inline constexpr int kResultsSchemaVersion = 1;

void write_text_atomic(const std::filesystem::path& file, const std::string& text);
std::string read_text(const std::filesystem::path& file);

std::string csv_escape(const std::string& field);
std::string csv_row(const std::vector<std::string>& fields);

// Appends rows to a CSV file as they come, flushing each, so a crashed cell keeps what it measured.
class CsvAppender {
 public:
  CsvAppender(const std::filesystem::path& file, const std::vector<std::string>& header);
  ~CsvAppender();
  CsvAppender(const CsvAppender&) = delete;
  CsvAppender& operator=(const CsvAppender&) = delete;
  void row(const std::vector<std::string>& fields);

 private:
  std::FILE* file_ = nullptr;
};

// Reads a CSV file written by csv_row: the header, then rows (quoted fields unescaped).
std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& file);

}  // namespace pb::io
