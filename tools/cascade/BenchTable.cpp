#include "BenchTable.h"

#include "libsph/io/AtomicFile.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace cascade::cli {

BenchTable::BenchTable(std::string bench, std::vector<std::string> columns)
    : mBench(std::move(bench)), mColumns(std::move(columns)) {}

void BenchTable::addRow(std::vector<Value> row) {
  if (row.size() != mColumns.size())
    throw std::logic_error("bench " + mBench + ": row has " + std::to_string(row.size()) +
                           " values for " + std::to_string(mColumns.size()) + " columns");
  mRows.push_back(std::move(row));
}

namespace {
std::string toText(const BenchTable::Value& value) {
  if (const auto* text = std::get_if<std::string>(&value)) return *text;
  if (const auto* integer = std::get_if<long long>(&value)) return std::to_string(*integer);
  if (!std::isfinite(std::get<double>(value))) return "-";  // not measured in this row (JSON: null)
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.4g", std::get<double>(value));
  return buffer;
}
} // namespace

std::string BenchTable::format() const {
  std::vector<std::size_t> widths;
  for (const auto& column : mColumns) widths.push_back(column.size());
  for (const auto& row : mRows)
    for (std::size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], toText(row[c]).size());
  std::ostringstream out;
  auto line = [&](const std::vector<std::string>& cells) {
    for (std::size_t c = 0; c < cells.size(); ++c) {
      out << (c ? "  " : "");
      out << std::string(widths[c] - cells[c].size(), ' ') << cells[c];
    }
    out << '\n';
  };
  line(mColumns);
  for (const auto& row : mRows) {
    std::vector<std::string> cells;
    for (const auto& value : row) cells.push_back(toText(value));
    line(cells);
  }
  return out.str();
}

void BenchTable::writeJson(const std::filesystem::path& path) const {
  nlohmann::json results = nlohmann::json::array();
  for (const auto& row : mRows) {
    nlohmann::json object = nlohmann::json::object();
    for (std::size_t c = 0; c < row.size(); ++c)
      std::visit([&](const auto& value) { object[mColumns[c]] = value; }, row[c]);
    results.push_back(object);
  }
  const nlohmann::json document = {{"bench", mBench}, {"results", results}};
  writeTextAtomically(path, document.dump(2) + "\n");
}

} // namespace cascade::cli
