/// @file BenchTable.h
/// @brief A benchmark's result table: printed aligned on stdout and written as
///        {"bench": NAME, "results": [{column: value, ...}, ...]} with --json.
#pragma once

#include <filesystem>
#include <string>
#include <variant>
#include <vector>

namespace cascade::cli {

class BenchTable {
public:
  using Value = std::variant<std::string, long long, double>;

  BenchTable(std::string bench, std::vector<std::string> columns);

  /// Appends a row; values in column order.
  void addRow(std::vector<Value> row);

  const std::string& bench() const { return mBench; }
  const std::vector<std::string>& columns() const { return mColumns; }
  const std::vector<std::vector<Value>>& rows() const { return mRows; }

  /// The aligned text table.
  std::string format() const;
  /// Writes the JSON form, atomically.
  void writeJson(const std::filesystem::path& path) const;

private:
  std::string mBench;
  std::vector<std::string> mColumns;
  std::vector<std::vector<Value>> mRows;
};

} // namespace cascade::cli
