/// @file SolverTestScenes.h
/// @brief Scenes shared by the solver tests: the Martin & Moyce (1952) dam
///        break (n^2 = 2) as a quasi-2D slab between free-slip walls, and a
///        resting water column in a tank.
#pragma once

#include "libsph/boundary/BoxBoundary.h"
#include "libsph/solver/Simulation.h"

#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace cascade::test {

/// Martin & Moyce: column width a = 2.25 in, height 2a (n^2 = 2).
constexpr double kMartinMoyceA = 0.05715;

/// Slab thickness in spacings (the y walls are free-slip mirrors: quasi 2D).
constexpr int kSlabLayers = 4;

inline SimulationSettings damBreakSettings(double spacing) {
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.neighborSearch = "grid";
  return settings;
}

/// Column [0, a] x [0, W] x [0, 2a] in a tank [0, 8a] x [0, W] x [0, 4a].
inline std::unique_ptr<Simulation> makeDamBreak(const SimulationSettings& settings) {
  const Real a = Real(kMartinMoyceA), s = settings.fluid.spacing;
  const Real width = s * kSlabLayers;
  auto sim = std::make_unique<Simulation>(settings);
  sim->addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(8 * a, width, 4 * a)));
  sim->addFluidBox(Vec3r(0, 0, 0), Vec3r(a, width, 2 * a));
  return sim;
}

/// A resting water column side x side x height (spacing `spacing`) in a tank
/// twice as tall, the given (by default the default) solver settings.
inline std::unique_ptr<Simulation> makeRestingTank(double side, double height, double spacing,
                                                   SimulationSettings settings = {}) {
  settings.fluid.spacing = Real(spacing);
  auto sim = std::make_unique<Simulation>(settings);
  sim->addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(2 * height))));
  sim->addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(height)));
  return sim;
}

/// Rows of a CSV file with '#' comments and one header line.
inline std::vector<std::vector<std::string>> readCsv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) { header = false; continue; }
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

inline std::string dataPath(const std::string& name) {
  return std::string(CASCADE_SOURCE_DIR) + "/tests/solver/data/" + name;
}

} // namespace cascade::test
