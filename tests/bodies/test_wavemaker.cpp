// Piston wavemaker (issue 16, label long): the shipped flume (scenes/wavemaker.json,
// kd = 1.0, stroke 0.03 m, period 0.727 s) makes waves whose height, read about three
// wavelengths from the paddle before the far wall's reflection arrives, matches
// Biesel's linear transfer function H / S = 2 (cosh 2kd - 1) / (sinh 2kd + 2kd)
// within 10 %. Overrides of the scene (solver, spacing, viscosity) come from
// CASCADE_WAVEMAKER_SET ("key=value;key=value").
//
// Known failure (docs/moving-solids.md): the paddle puts in the energy flux of
// Biesel's wave (102 % at 5 mm) and the wave one wavelength out is 93 % of it,
// but the waves lose about 10 % of their height per wavelength to the method's
// dissipation: 68 % at three wavelengths (5 mm, 18 min), 55 % at 1 cm (70 s).
#include "libsph/probes/Probes.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/Simulation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

namespace cascade::test {

namespace {

/// Wave number of period T in depth d: omega^2 = g k tanh(k d), by fixed-point iteration.
double waveNumber(double period, double depth) {
  const double omega = 2 * M_PI / period, g = 9.81;
  double k = omega * omega / g;
  for (int i = 0; i < 200; ++i) k = omega * omega / (g * std::tanh(k * depth));
  return k;
}

double bieselRatio(double kd) { return 2 * (std::cosh(2 * kd) - 1) / (std::sinh(2 * kd) + 2 * kd); }

std::vector<std::string> overrides(std::vector<std::string> sets) {
  if (const char* extra = std::getenv("CASCADE_WAVEMAKER_SET")) {
    std::stringstream in(extra);
    std::string item;
    while (std::getline(in, item, ';'))
      if (!item.empty()) sets.push_back(item);
  }
  return sets;
}

} // namespace

TEST(Wavemaker, WaveHeightFollowsBiesel) {
  const std::string file = std::string(CASCADE_SOURCE_DIR) + "/scenes/wavemaker.json";
  scene::Scene scene = scene::loadScene(file, overrides({"size=seed"}));
  const scene::Piston& piston = *scene.boundaries.obstacles.at(0).motion->piston;
  const double depth = scene.fluid.blocks.at(0).box.max[2];
  const double k = waveNumber(piston.period, depth), kd = k * depth;
  const double expected = bieselRatio(kd) * piston.stroke;
  const double paddle = scene.boundaries.obstacles.at(0).translate[0] + 0.01;  // its front face at rest
  const double wavelength = 2 * M_PI / k, y = 0.5 * scene.fluid.blocks.at(0).box.max[1];
  const double x1 = paddle + wavelength, x3 = paddle + 3 * wavelength;
  Simulation sim(scene::simulationSettings(scene));
  scene::setUpSimulation(scene, sim, nullptr);
  // Heights every 10 ms; the window: from when the ramped-up wave front (group speed) has
  // passed the far probe by a period to 0.5 s before the far wall's reflection gets back.
  const double omega = 2 * M_PI / piston.period, c = omega / k;
  const double cg = 0.5 * c * (1 + 2 * kd / std::sinh(2 * kd));
  const double length = scene.boundaries.tank->max[0];
  const double start = piston.ramp + (x3 - paddle) / cg + piston.period;
  const double end = (2 * length - paddle - x3) / cg - 0.5;
  ASSERT_GT(end - start, 3 * piston.period) << "window " << start << "-" << end << " s";
  std::vector<double> t, h1, h3;
  for (double time = 0.01; time <= end + 1e-9; time += 0.01) {
    sim.advanceTo(time);
    if (time < start) continue;
    t.push_back(time);
    h1.push_back(waterHeight(sim.particles().position, x1, y, Real(scene.fluid.spacing)));
    h3.push_back(waterHeight(sim.particles().position, x3, y, Real(scene.fluid.spacing)));
  }
  // Crest to trough per period over the window, averaged.
  const auto meanHeight = [&](const std::vector<double>& h) {
    double sum = 0;
    int periods = 0;
    for (double from = start; from + piston.period <= end; from += piston.period, ++periods) {
      double top = -1e9, bottom = 1e9;
      for (std::size_t i = 0; i < t.size(); ++i)
        if (t[i] >= from && t[i] < from + piston.period && std::isfinite(h[i]))
          top = std::max(top, h[i]), bottom = std::min(bottom, h[i]);
      sum += top - bottom;
    }
    return sum / periods;
  };
  const double near = meanHeight(h1), mean = meanHeight(h3);
  std::cout << "wavemaker (" << scene.solver.type << ", spacing " << scene.fluid.spacing << ", kd " << kd
            << ", window " << start << "-" << end << " s): H at one wavelength " << near << " m ("
            << 100 * (near / expected - 1) << " %), at three " << mean << " m (" << 100 * (mean / expected - 1)
            << " %), Biesel " << expected << " m, " << sim.stepCount() << " steps\n";
  EXPECT_NEAR(mean / expected, 1.0, 0.10);
}

} // namespace cascade::test
