// Standing wave (validation): the first sloshing mode of a closed flume, started flat
// with the linear mode's velocity field, oscillates at the linear dispersion relation's
// period omega^2 = g k tanh(k d) (k = pi / L) and keeps its amplitude: the solver's
// numerical damping of gravity waves, measured in a second, not over a flume of
// wavelengths (docs/solvers.md, "Gravity waves").
//
// The mode (Dean & Dalrymple, "Water wave mechanics", standing wave): surface
// eta = a cos(k x) sin(omega t), velocity
//   u = -a omega sin(k x) cosh(k z) / sinh(k d) cos(omega t),
//   w =  a omega cos(k x) sinh(k z) / sinh(k d) cos(omega t)   (z above the floor).
// Its amplitude A(t) is the projection of the particle velocities on the mode's
// velocity field (A(0) = a). The decay per period is the slope of ln |A| over the
// extremes of A; the period is twice the mean spacing of its zero crossings.
// A progressive wave of the same kd loses per wavelength what the mode loses in
// lambda / c_g = T / (c_g / c) (energy travels at the group speed c_g): printed.
//
// What the lost amplitude becomes (CASCADE_TEST_VERBOSE prints it): kinetic energy
// outside the mode, nine tenths of it at the particle scale (not in 3 cm cell means),
// first in the top two layers, then everywhere (docs/solvers.md, "Gravity waves").
//
// For studies: CASCADE_WAVE_SPACING, _AMPLITUDE, _PERIODS, _WIDTH (slab, in spacings),
// _FROM_SURFACE (start at rest with the surface raised), _ALPHA (artificial viscosity),
// _VISCOSITY (Pa s), _SUPPORT (support radius over spacing), _TOLERANCE,
// _DIVERGENCE_TOLERANCE, _ITERATIONS, _MAX_DT; WCSPH: _CONTINUITY (delta: continuity density),
// _APPROACHING_ONLY (artificial viscosity), _CUBIC / _WENDLAND (kernels), _NO_SURFACE_LAYER,
// _NO_TYPE1 (no repulsion particles), _SAMPLE_GAP (of r0), _R0 (SEED (11)'s r0 in spacings),
// _NO_CLAMP (negative pressure), _TAIT, _SYMMETRIC (pressure force), _SOUND (speed of sound,
// m/s), _VELOCITY_FILTER (its beta).
// Verbose runs also print KE+PE, the kinetic and gravitational energy per unit particle
// mass against the start, and (WCSPH, linear equation of state) the elastic energy: their
// sum is conserved by an exact Hamiltonian run (docs/solvers.md, "Gravity waves").
#include "TestEnvironment.h"

#include "libsph/boundary/BoxBoundary.h"
#include "libsph/solver/Simulation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

namespace cascade::test {

namespace {

/// A damped oscillation from its samples: period from the zero crossings, decay from
/// ln |extreme| (one per half period) against time.
class Oscillation {
public:
  void add(double t, double value) {
    if (mCount > 0 && (value > 0) != (mPrevious > 0)) {
      mCrossings.push_back(t - (t - mPreviousTime) * value / (value - mPrevious));  // linear interpolation
      mPeakTime.push_back(mExtremeTime);
      mPeakValue.push_back(std::abs(mExtreme));
      mExtreme = 0;
    }
    if (std::abs(value) > std::abs(mExtreme)) mExtreme = value, mExtremeTime = t;
    mPrevious = value, mPreviousTime = t, ++mCount;
  }
  int extremes() const { return int(mPeakValue.size()); }
  /// Twice the mean spacing of the zero crossings (0 if fewer than two).
  double period() const {
    return mCrossings.size() < 2 ? 0 : 2 * (mCrossings.back() - mCrossings.front()) / double(mCrossings.size() - 1);
  }
  /// The amplitude ratio over `time`: exp(slope time) of the least-squares line through ln |extreme|.
  double keptOver(double time) const {
    const double n = double(mPeakValue.size());
    if (n < 2) return 0;
    double st = 0, sl = 0, stt = 0, stl = 0;
    for (std::size_t i = 0; i < mPeakValue.size(); ++i) {
      const double l = std::log(mPeakValue[i]);
      st += mPeakTime[i], sl += l, stt += mPeakTime[i] * mPeakTime[i], stl += mPeakTime[i] * l;
    }
    return std::exp((n * stl - st * sl) / (n * stt - st * st) * time);
  }

private:
  std::vector<double> mCrossings, mPeakTime, mPeakValue;
  double mPrevious = 0, mPreviousTime = 0, mExtreme = 0, mExtremeTime = 0;
  long mCount = 0;
};

struct Sloshing {
  double period = 0, linearPeriod = 0;  ///< s
  double keptPerPeriod = 0;             ///< the mode's amplitude ratio over one period
  double keptPerWavelength = 0;         ///< the same damping for a progressive wave
  double meanVelocityKept = 0;          ///< kept per period from the mean horizontal velocity
  int extremes = 0;
  double floorLayer = 0;        ///< mean height of the particles within a spacing of the floor at the end, spacings
  double meanHeightChange = 0;  ///< the particles' mean height at the end less at the start, spacings
  std::uint64_t keptOut = 0;    ///< particles the guard put back out of the walls
  std::vector<double> kinetic;  ///< sum of |v|^2 / 2 over the particles at each sample (T / 200), J/kg
};

/// r0: SEED (11)'s repulsion radius in spacings (0: the default, where the resting wall layer sits).
/// configure: changes to the settings (before the CASCADE_WAVE_* overrides); layers: the
/// slab's width in spacings (0: CASCADE_WAVE_WIDTH or 2); amplitude (m) and spacing (m):
/// 0 for CASCADE_WAVE_AMPLITUDE or 1 cm, CASCADE_WAVE_SPACING or 1 cm; periods: 0 for
/// CASCADE_WAVE_PERIODS or 3.
Sloshing slosh(const std::string& solver, double artificialViscosity, double r0 = 0,
               const std::function<void(SimulationSettings&)>& configure = {}, double layers = 0,
               double amplitudeOverride = 0, double spacingOverride = 0, int periodsOverride = 0) {
  const double spacing = spacingOverride > 0 ? spacingOverride : envOr("CASCADE_WAVE_SPACING", 0.01);
  const double length = 0.3, depth = 0.1, width = (layers > 0 ? layers : envOr("CASCADE_WAVE_WIDTH", 2)) * spacing;
  const double a = amplitudeOverride > 0 ? amplitudeOverride : envOr("CASCADE_WAVE_AMPLITUDE", 0.01);
  const double g = kStandardGravity, k = M_PI / length, kd = k * depth;
  const double omega = std::sqrt(g * k * std::tanh(kd));
  const bool fromSurface = std::getenv("CASCADE_WAVE_FROM_SURFACE") != nullptr;
  Sloshing result;
  result.linearPeriod = 2 * M_PI / omega;

  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = solver;
  settings.solver.artificialViscosity = Real(artificialViscosity);
  if (configure) configure(settings);
  if (const char* v = std::getenv("CASCADE_WAVE_ALPHA")) settings.solver.artificialViscosity = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_VISCOSITY")) settings.fluid.viscosity = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_DIVERGENCE_TOLERANCE")) settings.solver.divergenceTolerance = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_TOLERANCE")) settings.solver.densityTolerance = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_ITERATIONS")) settings.solver.maxIterations = std::atoi(v);
  if (const char* v = std::getenv("CASCADE_WAVE_MAX_DT")) settings.solver.maxTimeStep = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_SUPPORT")) settings.solver.supportRadiusFactor = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_CONTINUITY")) {
    settings.solver.density = DensityEvolution::Continuity;
    settings.solver.densityDiffusion = Real(std::atof(v));
  }
  if (std::getenv("CASCADE_WAVE_APPROACHING_ONLY")) settings.solver.artificialViscosityAllPairs = false;
  if (std::getenv("CASCADE_WAVE_CUBIC")) settings.solver.kernels = KernelPair::CubicSpline;
  if (std::getenv("CASCADE_WAVE_WENDLAND")) settings.solver.kernels = KernelPair::WendlandC2;
  if (std::getenv("CASCADE_WAVE_NO_CLAMP")) settings.solver.clampNegativePressure = false;
  if (std::getenv("CASCADE_WAVE_TAIT")) settings.solver.equationOfState = EquationOfState::Tait;
  if (std::getenv("CASCADE_WAVE_SYMMETRIC")) settings.solver.pressureForce = PressureForce::Symmetric;
  if (const char* v = std::getenv("CASCADE_WAVE_SOUND")) settings.solver.stiffness = Real(std::atof(v) * std::atof(v));
  if (const char* v = std::getenv("CASCADE_WAVE_VELOCITY_FILTER")) settings.solver.velocityFilter = Real(std::atof(v));
  if (std::getenv("CASCADE_WAVE_NO_SURFACE_LAYER")) settings.solver.surfaceLayerPressure = false;
  if (std::getenv("CASCADE_WAVE_NO_TYPE1")) settings.boundary.repulsionParticles = false;
  if (std::getenv("CASCADE_WAVE_MIRROR_HYDROSTATIC")) settings.boundary.mirrorHydrostatic = true;
  if (const char* v = std::getenv("CASCADE_WAVE_SAMPLE_GAP")) settings.boundary.sampleGap = Real(std::atof(v));
  settings.boundary.repulsionRadius = Real(envOr("CASCADE_WAVE_R0", r0) * spacing);
  Simulation sim(settings);
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(length), Real(width), Real(3 * depth))));
  // The mode's velocity per unit amplitude at a point.
  auto mode = [&](const Vec3r& x) {
    const double s = std::sinh(kd);
    return Vec3d(-omega * std::sin(k * x.x()) * std::cosh(k * x.z()) / s, 0,
                 omega * std::cos(k * x.x()) * std::sinh(k * x.z()) / s);
  };
  if (fromSurface) {
    // At rest with the surface raised by a cos(k x): the lattice points below it (the
    // mode a quarter period earlier, as a staircase).
    const long nx = std::lround(length / spacing), ny = std::lround(width / spacing);
    for (long i = 0; i < nx; ++i)
      for (long j = 0; j < ny; ++j)
        for (long l = 0;; ++l) {
          const Vec3r x = Real(spacing) * Vec3r(Real(i + 0.5), Real(j + 0.5), Real(l + 0.5));
          if (x.z() > depth + a * std::cos(k * x.x())) break;
          sim.addParticle(x, Vec3r::Zero());
        }
  } else {
    sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(length), Real(width), Real(depth)));
    Particles& p = sim.particles();
    for (std::size_t i = 0; i < p.size(); ++i) p.velocity[i] = (a * mode(p.position[i])).cast<Real>();
  }
  // The mode's amplitude: the velocities projected on its velocity field.
  auto amplitude = [&]() {
    const Particles& p = sim.particles();
    double along = 0, norm = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Vec3d m = mode(p.position[i]);
      along += p.velocity[i].cast<double>().dot(m);
      norm += m.squaredNorm();
    }
    return along / norm;
  };
  auto meanVelocity = [&]() {
    const Particles& p = sim.particles();
    double sum = 0;
    for (std::size_t i = 0; i < p.size(); ++i) sum += p.velocity[i].x();
    return sum / double(p.size());
  };

  // Gravitational energy per unit particle mass, summed over the particles.
  auto potential = [&]() {
    double sum = 0;
    for (const Vec3r& x : sim.particles().position) sum += g * double(x.z());
    return sum;
  };
  const double potential0 = potential();
  const int periods = periodsOverride > 0 ? periodsOverride : int(envOr("CASCADE_WAVE_PERIODS", 3));
  const double end = periods * result.linearPeriod, sample = result.linearPeriod / 200;
  Oscillation mode1, mean;
  for (int s = 1; s * sample <= end + 1e-12; ++s) {
    const double t = s * sample;
    sim.advanceTo(t);
    const double A = amplitude(), u = meanVelocity();
    double kinetic = 0;
    for (const Vec3r& v : sim.particles().velocity) kinetic += 0.5 * v.cast<double>().squaredNorm();
    result.kinetic.push_back(kinetic);
    if (std::getenv("CASCADE_TEST_VERBOSE")) {
      const Particles& p = sim.particles();
      double modeKinetic = 0, top = 0, wall = 0, middle = 0, elastic = 0;
      const bool wcsph = solver == "wcsph";
      for (std::size_t i = 0; i < p.size(); ++i) {
        // WCSPH's elastic energy per unit mass of the linear EOS clamped at 0,
        // u = k (ln q + 1 / q - 1) for q = rho / rho_0 > 1 (du = p / rho^2 drho)
        const double q = double(p.density[i]) / double(settings.fluid.restDensity);
        if (wcsph && q > 1) elastic += double(sim.constants().stiffness) * (std::log(q) + 1 / q - 1);
        modeKinetic += 0.5 * A * A * mode(p.position[i]).squaredNorm();
        const double r = 0.5 * (p.velocity[i].cast<double>() - A * mode(p.position[i])).squaredNorm();
        const Vec3r x = p.position[i];
        if (x.z() > depth - 2 * spacing) top += r;
        else if (x.z() < 2 * spacing || x.x() < 2 * spacing || x.x() > length - 2 * spacing) wall += r;
        else middle += r;
      }
      // the residual's large-scale part: its means over cells of 3 cm (x, z)
      const double cell = 0.03;
      const int cx = int(std::ceil(length / cell)), cz = int(std::ceil(2 * depth / cell));
      std::vector<Vec3d> sum(std::size_t(cx * cz), Vec3d::Zero());
      std::vector<int> count(std::size_t(cx * cz), 0);
      for (std::size_t i = 0; i < p.size(); ++i) {
        const Vec3r x = p.position[i];
        const int ix = std::clamp(int(x.x() / cell), 0, cx - 1), iz = std::clamp(int(x.z() / cell), 0, cz - 1);
        sum[std::size_t(ix * cz + iz)] += p.velocity[i].cast<double>() - A * mode(x);
        ++count[std::size_t(ix * cz + iz)];
      }
      double large = 0;
      for (std::size_t c = 0; c < sum.size(); ++c)
        if (count[c] > 0) large += 0.5 * sum[c].squaredNorm() / count[c];
      std::cout << "  t " << t << " A " << A << " KE " << kinetic << " mode KE " << modeKinetic << " rest: top "
                << top << " walls " << wall << " middle " << middle << " large-scale " << large << " KE+PE " << kinetic + potential() - potential0 << " elastic " << elastic << "\n";
    }
    mode1.add(t, A);
    mean.add(t, u);
  }
  {
    const Particles& p = sim.particles();
    double floor = 0, height = 0;
    std::size_t floorCount = 0;
    for (const Vec3r& x : p.position) {
      height += double(x.z());
      if (x.z() < spacing) floor += double(x.z()), ++floorCount;
    }
    result.floorLayer = floorCount ? floor / double(floorCount) / spacing : 0;
    result.meanHeightChange = (height * g - potential0) / g / double(p.size()) / spacing;
    result.keptOut = sim.keptOutCount();
  }
  result.extremes = mode1.extremes();
  result.period = mode1.period();
  result.keptPerPeriod = mode1.keptOver(result.linearPeriod);
  result.meanVelocityKept = mean.keptOver(result.linearPeriod);
  const double groupOverPhase = 0.5 * (1 + 2 * kd / std::sinh(2 * kd));
  result.keptPerWavelength = std::pow(result.keptPerPeriod, 1 / groupOverPhase);
  std::cout << "standing wave (" << solver << ", spacing " << spacing << ", a " << a << ", kd " << kd
            << (fromSurface ? ", from the raised surface" : ", from the mode's velocity") << ", "
            << sim.particles().size() << " particles, " << sim.stepCount() << " steps, " << sim.keptOutCount() << " kept out of walls): period " << result.period
            << " s (linear " << result.linearPeriod << " s, " << 100 * (result.period / result.linearPeriod - 1)
            << " %), floor layer at " << result.floorLayer << " spacing, mean height changed by "
            << result.meanHeightChange << " spacing, amplitude kept per period " << result.keptPerPeriod << " (mean velocity: "
            << result.meanVelocityKept << "; a progressive wave: per wavelength " << result.keptPerWavelength
            << ") over " << result.extremes << " extremes\n";
  return result;
}

} // namespace

/// A solver and the artificial viscosity its shipped scenes use (DFSPH's flume: none), and
/// the least amplitude it keeps per period today (a guard, not the target).
struct WaveCase {
  std::string solver;
  double artificialViscosity;
  double keptGuard = 0;
  double repulsionRadius = 0;  ///< r0 in spacings (0: the default)
  std::string name;
};

class StandingWave : public ::testing::TestWithParam<WaveCase> {};

std::string waveCaseName(const ::testing::TestParamInfo<WaveCase>& info) {
  return info.param.name.empty() ? info.param.solver : info.param.name;
}

#ifndef CASCADE_KNOWN_FAILURES
// Measured at 1 cm (10 layers deep, 6 per wave height), in a slab 2 layers wide:
// - DFSPH: period -3.1 %, amplitude kept per period 0.87 (0.81 before the tank imaged
//   both side walls' edges with the floor, BoxBoundary::mirrorMaps);
// - WCSPH (Wendland C2 at 2.15 spacings, artificial viscosity 0.1): period +0.6 %, kept
//   0.59 (0.39 before). At 2 spacings its resting lattice is rigid in shear and the
//   period is 14.8 % short (14.5 % at 5 mm, 14.1 % at 2.5 mm; the same with any
//   artificial viscosity or amplitude): this test fails there.
// - WCSPH with r0 of SEED (11) at 0.4 spacing, inside the resting wall layer's distance
//   (the setting docs/solvers.md gives for waves): kept 0.60 (0.59 before; 0.75 at 5 mm).
// The damping bounds guard today's values; the target (below) is the flume's.
TEST_P(StandingWave, OscillatesAtTheLinearPeriod) {
  const Sloshing s = slosh(GetParam().solver, GetParam().artificialViscosity, GetParam().repulsionRadius);
  ASSERT_GE(s.extremes, 4);
  EXPECT_NEAR(s.period / s.linearPeriod, 1.0, 0.05);
  EXPECT_GT(s.keptPerPeriod, GetParam().keptGuard);
}
INSTANTIATE_TEST_SUITE_P(BothSolvers, StandingWave,
                         ::testing::Values(WaveCase{"dfsph", 0.0, 0.83, 0, ""}, WaveCase{"wcsph", 0.1, 0.5, 0, ""},
                                           WaveCase{"wcsph", 0.1, 0.5, 0.4, "wcsph_r0_inside_the_wall_layer"}),
                         waveCaseName);

/// The velocity filter's beta of the shipped flume (scenes/wavemaker.json).
constexpr double kWavesVelocityFilter = 0.12;

/// WCSPH set for waves (docs/solvers.md, "Gravity waves"; scenes/wavemaker.json):
/// continuity density with delta-SPH 0.1, Wendland C2 at 3 spacings, no artificial
/// viscosity, no type I particles, the bi-Laplacian velocity filter.
void setForWaves(SimulationSettings& settings, bool hydrostaticImages, double velocityFilter = kWavesVelocityFilter) {
  settings.solver.density = DensityEvolution::Continuity;
  settings.solver.densityDiffusion = Real(0.1);
  settings.solver.velocityFilter = Real(velocityFilter);
  settings.solver.supportRadiusFactor = Real(3);
  settings.boundary.repulsionParticles = false;
  settings.boundary.mirrorHydrostatic = hydrostaticImages;
}

// Without type I particles the mirror images alone hold the water off the walls. With their
// hydrostatic pressure (BoundarySettings::mirrorHydrostatic) the floor layer stays where
// it rests, half a spacing up, and the guard hardly acts; with the sources' pressure alone
// the images carry too little of the water's weight, and the layer sinks to the guard's
// quarter spacing. Either way the water keeps its volume: the continuity density counts
// the guard's moves (TimeStep::finishStep). Before it did, the flume's water lost 4 % of
// its depth in 8 s (docs/solvers.md).
TEST(StandingWaveForWaves, TheImagesHoldTheFloorLayerAndTheWaterKeepsItsVolume) {
  const Sloshing held = slosh("wcsph", 0.0, 0, [](SimulationSettings& s) { setForWaves(s, true); }, 6);
  const Sloshing sunk = slosh("wcsph", 0.0, 0, [](SimulationSettings& s) { setForWaves(s, false); }, 6);
  EXPECT_NEAR(held.floorLayer, 0.5, 0.05);
  EXPECT_LT(sunk.floorLayer, 0.4);
  EXPECT_LT(double(held.keptOut), 0.1 * double(sunk.keptOut));
  EXPECT_NEAR(held.meanHeightChange, 0.0, 0.02);
  EXPECT_NEAR(sunk.meanHeightChange, 0.0, 0.02);
  EXPECT_NEAR(held.period / held.linearPeriod, 1.0, 0.025);  // -2.1 % (-1.8 % without the velocity filter)
  EXPECT_GT(held.keptPerPeriod, 0.98);                       // 0.990 (0.99 without the filter)
}

// A slab 2 layers wide, narrower than twice the support: every particle lies within range
// of both side walls, and those next to the floor need the images across the floor's edge
// with the far wall as much as with the near one. When the tank gave them only the edge of
// the first wall in range (y = 0), the floor layer by the other wall missed a quadrant of
// its kernel sum and sank: WCSPH set for waves (3 spacings of support) lost 0.56 spacing of
// mean height in three periods with 10,381 guard actions and kept 0.81 a period, DFSPH's
// floor layer sat at 0.44 spacing. Now the water keeps its depth and its floor layer, and
// the wave its amplitude (0.99 a period for WCSPH set for waves, 0.87 for DFSPH).
TEST(StandingWaveInANarrowSlab, TheFloorLayerRestsByBothSideWalls) {
  const Sloshing wcsph = slosh("wcsph", 0.0, 0, [](SimulationSettings& s) { setForWaves(s, true); }, 2);
  EXPECT_NEAR(wcsph.floorLayer, 0.5, 0.03);
  EXPECT_NEAR(wcsph.meanHeightChange, 0.0, 0.02);
  EXPECT_LT(wcsph.keptOut, 10u);
  EXPECT_GT(wcsph.keptPerPeriod, 0.95);
  const Sloshing dfsph = slosh("dfsph", 0.0, 0, {}, 2);
  EXPECT_NEAR(dfsph.floorLayer, 0.5, 0.03);
  EXPECT_NEAR(dfsph.meanHeightChange, 0.0, 0.01);
}

// Still water set for waves is unstable without the velocity filter: continuity density
// with delta-SPH at 3 spacings of support lets a particle-scale motion grow from round-off
// (a zigzag of vertical velocity between neighbouring columns), at a rate that grows with
// delta and the support and not with the time step (docs/solvers.md, "Still water set for
// waves"). At 2 cm, five layers deep, over 30 periods (21 s): without the filter the kinetic
// energy falls to about 5e-7 J/kg after the start, then grows a thousandfold by 3 s; with
// it, it keeps falling for 7 s, and what grows later (layers sliding over each other, a
// scale the bi-Laplacian reaches less) peaks more than ten times lower. A run takes 4 s.
TEST(StillWaterForWaves, TheVelocityFilterHoldsTheParticleScaleDown) {
  const auto still = [](double velocityFilter) {
    return slosh("wcsph", 0.0, 0, [&](SimulationSettings& s) { setForWaves(s, true, velocityFilter); }, 2, 1e-9, 0.02,
                 30);
  };
  const Sloshing bare = still(0), filtered = still(kWavesVelocityFilter);
  ASSERT_EQ(bare.kinetic.size(), 6000u);
  ASSERT_EQ(filtered.kinetic.size(), 6000u);
  // Samples are T / 200 apart (T = 0.70 s): sample 500 is at 1.75 s, after the start has
  // rung down, sample 1600 at 5.6 s.
  const auto most = [](const Sloshing& s, std::size_t from) {
    return *std::max_element(s.kinetic.begin() + long(from), s.kinetic.end());
  };
  std::cout << "still water set for waves, 2 cm, kinetic energy (J/kg) at 1.75 s, 5.6 s, peak after 1.75 s: without "
               "the velocity filter "
            << bare.kinetic[500] << ", " << bare.kinetic[1600] << ", " << most(bare, 500) << "; with it "
            << filtered.kinetic[500] << ", " << filtered.kinetic[1600] << ", " << most(filtered, 500) << "\n";
  EXPECT_GT(bare.kinetic[1600], 100 * bare.kinetic[500]);  // grown
  EXPECT_LT(filtered.kinetic[1600], filtered.kinetic[500]);  // still falling
  EXPECT_LT(most(filtered, 500), 0.1 * most(bare, 500));   // and its peak far lower
}

#else
// The target: a wave that keeps 97 % of its amplitude per period keeps 96.5 % per
// wavelength travelling (kd = 1), which the flume needs to stay within 10 % of Biesel
// three wavelengths out. DFSPH keeps 0.81 per period at 1 cm; WCSPH (artificial
// viscosity 0.1) 0.39.
TEST_P(StandingWave, KeepsItsAmplitude) {
  const Sloshing s = slosh(GetParam().solver, GetParam().artificialViscosity);
  ASSERT_GE(s.extremes, 4);
  EXPECT_NEAR(s.period / s.linearPeriod, 1.0, 0.05);
  EXPECT_GT(s.keptPerPeriod, 0.97);
}
INSTANTIATE_TEST_SUITE_P(BothSolvers, StandingWave,
                         ::testing::Values(WaveCase{"dfsph", 0.0, 0, 0, ""}, WaveCase{"wcsph", 0.1, 0, 0, ""}), waveCaseName);
#endif

} // namespace cascade::test
