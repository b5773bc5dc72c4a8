/// @file BenchTable.h
/// @brief A benchmark's result table: printed aligned on stdout and written as
///        {"bench": NAME, "results": [{column: value, ...}, ...]} with --json.
#pragma once

#include <filesystem>
#include <functional>
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

  /// Work that needs the results but may fail (a plot): run by `cascade bench` after
  /// the table is printed and its JSON written, so a failure there loses neither.
  void setFinish(std::function<void()> finish) { mFinish = std::move(finish); }
  void finish() const {
    if (mFinish) mFinish();
  }

private:
  std::string mBench;
  std::vector<std::string> mColumns;
  std::vector<std::vector<Value>> mRows;
  std::function<void()> mFinish;
};

} // namespace cascade::cli
