// `cascade bench accuracy`: run time against error for each solver over a
// ladder of particle spacings.
//
// Per solver (wcsph, dfsph) and spacing s:
//  - dam break, Martin & Moyce (1952) n^2 = 2: a column a x W x 2a (a = 2.25 in,
//    W = 4 s: a slab with free-slip side walls) in a tank 8a x W x 4a, run to
//    kEndTime; the `front` probe (Probes.h surgeFront) against the surge-front
//    table, Z = x/a at T = t sqrt(2g/a), and the `height` probe at the back wall
//    against the residual-column table, H = h/(2a) at tau = t sqrt(g/a), each as
//    the RMS of the relative error over the table points the run covers;
//    wall_s is this run's wall time (set-up included), cpu_s its CPU time over all
//    threads (std::clock; comparable when other work shares the machine);
//  - hydrostatic tank: the same column in a tank of its own footprint, settled
//    for kSettleTime; the floor pressure (Probes.h pressureAt) against rho g 2a
//    and the compression mean(max(rho/rho_0 - 1, 0)) (average) and
//    max(rho/rho_0 - 1) (maximum), all averaged (the maximum: maximal) over the
//    samples of the last kSampleWindow.
//  - lobovsky, Lobovsky et al. (2014), H = 300 mm: scenes/lobovsky.json at spacing s,
//    run to t/T = 7 (T = sqrt(H/g)); its sensor-2 probe (a face of the scene's radius,
//    Probes.h pressureOverDisc) sampled every 0.5 ms (raw samples; only the peak is
//    taken after a filter), against the experiment's 2.5/50/97.5 percentile band
//    (scenes/validation/): peak_err, the first
//    impact's peak against the median's (onset at half the median's peak, peak within
//    0.25 T), as a signed fraction, of the probe's 5 ms centred moving average (a
//    transducer's response time; peak_err_raw: of the raw samples); peak_time_err, its
//    time error in T; band_fraction,
//    the samples within the band over t/T in [2.3, 7]; noise, the RMS of (raw - its 5 ms
//    centred moving average) over t/T in [3, 7], in rho g H. Spacings from
//    CASCADE_ACCURACY_LOBOVSKY (m; "none" skips the case). By default those that bake
//    in under 10 minutes here: 1 cm and 5 mm (DFSPH at 5 mm: 8.6 min, WCSPH about 9).
// Errors are fractions (0.03 = 3 %). front_rms and height_rms compare with the
// experiment's own time origin (raw). front_rms_release and height_rms_release
// compare with its time origin moved by kReleaseShift (T = 0.175, the correction
// codes that match the table apply, e.g. Lethe's Martin & Moyce example, attributed
// to the column's release): both, so that the shift's effect on the column height,
// which fits best unshifted, is in the table too. Prints the table,
// and with --json writes it and a log-log plot (gnuplot, pngcairo or png) of front
// error against wall time, one line per solver, next to the JSON (or to --plot).
//
// The fluid is water (mu = 1.0e-3 Pa s); floor and end walls are walls with the wall
// shear of a laminar boundary layer (MirrorSlip::LaminarWallShear, Stokes' first
// problem; DFSPH applies it, WCSPH treats it as free slip); the slab's y faces are
// symmetry planes (a 2-D flow), never walls.
//
// Environment (for quick runs): CASCADE_ACCURACY_SOLVERS="wcsph,dfsph",
// CASCADE_ACCURACY_RESOLUTIONS="8,12,18,27,36,54" (a / s, particles across the column;
// a/54 bakes in 23-29 s here; a/72 would take over 60 s, scaled by particles and steps).
// Diagnostics (convergence studies): CASCADE_ACCURACY_SLIP=free|no|laminar,
// CASCADE_ACCURACY_VISCOSITY (Pa s), CASCADE_ACCURACY_ARTIFICIAL_VISCOSITY (alpha),
// CASCADE_ACCURACY_DENSITY_TOLERANCE, CASCADE_ACCURACY_PARTICLE_SHARE (the per-particle
// share of it) and CASCADE_ACCURACY_PRECONDITIONER=two_level|jacobi (DFSPH), CASCADE_ACCURACY_TANK_ONLY=1 (no dam break),
// CASCADE_ACCURACY_DAMBREAK_ONLY=1 (no hydrostatic tank; its columns read nan),
// CASCADE_ACCURACY_CURVES=DIR (created; writes DIR/<solver>_<a/s>.dat: t, Z, T, H, tau per sample),
// CASCADE_ACCURACY_TIME_SHIFT=T0 (the release columns' shift in the surge table's T units,
// default 0.175), CASCADE_ACCURACY_DENSITY=summation|continuity (WCSPH's density; the
// Lobovsky scene's own is continuity), CASCADE_ACCURACY_DENSITY_DIFFUSION (delta),
// CASCADE_ACCURACY_CLAMP=0|1 (WCSPH's negative-pressure clamp; dam break and tank),
// CASCADE_ACCURACY_REPULSION=0|1 (type I boundary particles, SEED (11); dam break and tank),
// CASCADE_ACCURACY_REPULSION_RADIUS (r0 of SEED (11) in spacings; dam break and tank),
// CASCADE_ACCURACY_LOBOVSKY_SET="key=value;key=value" (scene overrides of the Lobovsky case).
// The plots: the dam break's error against wall time (--plot, or next to the JSON), and
// the Lobovsky sensor against the band, raw and 5 ms averaged ("-lobovsky" added to the name).
#include "Benchmarks.h"

#include "libsph/Errors.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/probes/ExperimentComparison.h"
#include "libsph/probes/Probes.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/Simulation.h"
#include "libsph/solver/TimeStepDFSPH.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <unistd.h>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace cascade::cli {

namespace {

constexpr double kA = 0.05715;           // m, Martin & Moyce column width a (2.25 in)
constexpr int kSlabLayers = 4;           // particles across the slab (y)
constexpr unsigned kSlabSides = 2;       // the slab's y faces are symmetry planes (a 2-D flow), not walls
constexpr double kEndTime = 0.3;         // s: T = 5.5, tau = 3.9
constexpr double kSampleInterval = 1e-3; // s between probe samples
constexpr double kSettleTime = 0.4;      // s, hydrostatic tank
constexpr double kSampleWindow = 0.1;    // s, hydrostatic averages over the end
// The release correction (surge table's T units): Lethe's Martin & Moyce example (time_correction
// in examples/multiphysics/dam-break/dam-break-2d.py); no source we found derives the value.
constexpr double kReleaseShift = 0.175;

// Martin & Moyce (1952) Table 2, n^2 = 2: surge front (Z = x/a, T = t sqrt(2g/a)).
// Martin & Moyce 1952, Phil. Trans. R. Soc. A 244:312-324, doi:10.1098/rsta.1952.0006, as
// transcribed in Ocellaris' scripts/plot_dam_break.py (Lethe's example agrees within 0.02 in T).
const TimeSeries kFrontTable = {
    {0.41, 1.11}, {0.84, 1.22}, {1.19, 1.44}, {1.43, 1.67}, {1.63, 1.89}, {1.83, 2.11}, {1.98, 2.33}, {2.2, 2.56},
    {2.32, 2.78}, {2.51, 3.0},  {2.65, 3.22}, {2.83, 3.44}, {2.98, 3.67}, {3.11, 3.89}, {3.33, 4.11}};
// Martin & Moyce (1952) Table 6, n^2 = 2: residual column at the back wall (H = h/(2a), tau = t sqrt(g/a)).
// Martin & Moyce 1952, doi:10.1098/rsta.1952.0006, as transcribed in Ocellaris' scripts/plot_dam_break.py.
const TimeSeries kHeightTable = {
    {0.56, 0.94}, {0.77, 0.89}, {0.93, 0.83}, {1.08, 0.78}, {1.28, 0.72}, {1.46, 0.67},
    {1.66, 0.61}, {1.84, 0.56}, {2.0, 0.5},   {2.21, 0.44}, {2.45, 0.39}, {2.7, 0.33},
    {3.06, 0.28}, {3.44, 0.22}, {4.2, 0.17},  {5.25, 0.11}, {7.4, 0.06}};

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// The value of environment variable `name` if it is one of `options`; "" if unset or
/// empty; anything else is an InputError (exit 2), never read as some default.
std::string environmentChoice(const char* name, std::initializer_list<const char*> options) {
  const char* v = std::getenv(name);
  if (v == nullptr || *v == 0) return "";
  std::string list;
  for (const char* option : options) {
    if (std::string(v) == option) return v;
    list += (list.empty() ? "" : ", ") + std::string(option);
  }
  throw InputError(std::string(name) + ": '" + v + "' is not one of " + list);
}

SimulationSettings settingsFor(const std::string& solver, double spacing) {
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = solver;
  // Each solver at its usual CFL number: WCSPH's includes the speed of sound.
  settings.solver.cflFactor = Real(solver == "dfsph" ? 0.5 : 0.4);
  // The experiment's fluid is water: mu = 1.0e-3 Pa s (20 C); its walls (floor, end walls)
  // exert the shear of a laminar boundary layer (WallShearStress.h; DFSPH, WCSPH: free slip).
  settings.fluid.viscosity = Real(1.0e-3);
  settings.boundary.slip = MirrorSlip::LaminarWallShear;
  // Diagnostics for convergence studies (the table uses the values above).
  if (const char* v = std::getenv("CASCADE_ACCURACY_ARTIFICIAL_VISCOSITY"); v && *v)
    settings.solver.artificialViscosity = Real(std::stod(v));
  if (const char* v = std::getenv("CASCADE_ACCURACY_VISCOSITY"); v && *v) settings.fluid.viscosity = Real(std::stod(v));
  if (const char* v = std::getenv("CASCADE_ACCURACY_DENSITY_TOLERANCE"); v && *v)
    settings.solver.densityTolerance = Real(std::stod(v));
  if (const char* v = std::getenv("CASCADE_ACCURACY_PARTICLE_SHARE"); v && *v)
    settings.solver.particleToleranceShare = Real(std::stod(v));
  if (const std::string v = environmentChoice("CASCADE_ACCURACY_PRECONDITIONER", {"two_level", "jacobi"}); !v.empty())
    settings.solver.twoLevelPreconditioner = v == "two_level";
  if (const std::string v = environmentChoice("CASCADE_ACCURACY_DENSITY", {"summation", "continuity"}); !v.empty())
    settings.solver.density = v == "continuity" ? DensityEvolution::Continuity : DensityEvolution::Summation;
  if (const char* v = std::getenv("CASCADE_ACCURACY_DENSITY_DIFFUSION"); v && *v)
    settings.solver.densityDiffusion = Real(std::stod(v));
  if (const std::string v = environmentChoice("CASCADE_ACCURACY_CLAMP", {"0", "1"}); !v.empty())
    settings.solver.clampNegativePressure = v == "1";
  if (const std::string v = environmentChoice("CASCADE_ACCURACY_REPULSION", {"0", "1"}); !v.empty())
    settings.boundary.repulsionParticles = v == "1";
  if (const char* v = std::getenv("CASCADE_ACCURACY_REPULSION_RADIUS"); v && *v)
    settings.boundary.repulsionRadius = Real(std::stod(v) * spacing);
  if (const std::string v = environmentChoice("CASCADE_ACCURACY_SLIP", {"no", "free", "laminar"}); !v.empty())
    settings.boundary.slip = v == "no" ? MirrorSlip::NoSlip : v == "free" ? MirrorSlip::FreeSlip : MirrorSlip::LaminarWallShear;
  return settings;
}

struct Row {
  std::string solver;
  double spacing = 0;
  long long fluid = 0;
  double wall = 0, frontRms = 0, heightRms = 0, pressureError = 0, densityAvg = 0, densityMax = 0;
  double frontRmsRelease = 0, heightRmsRelease = 0;  // the experiment's time origin moved by the release shift
  double hydroWall = 0, steps = 0, msPerStep = 0;
  double cpu = 0;  // s of CPU time of the dam-break run, all threads (the machine may be shared)
};

double releaseShift() {
  const char* v = std::getenv("CASCADE_ACCURACY_TIME_SHIFT");
  if (!v || !*v) return kReleaseShift;
  char* end = nullptr;
  const double shift = std::strtod(v, &end);
  if (*end != '\0' || !(shift >= 0 && shift < 5))
    throw InputError(std::string("CASCADE_ACCURACY_TIME_SHIFT: '") + v + "' is not a shift in [0, 5)");
  return shift;
}

/// Steps `sim` to endTime, calling sample() at the start and after the first step that
/// reaches each multiple of `interval`.
template <typename Sample>
void stepSampling(Simulation& sim, double endTime, double interval, Sample&& sample) {
  sample();
  double next = interval;
  while (sim.time() < endTime) {
    sim.step();
    if (sim.time() >= next - 1e-12) {
      sample();
      next = (std::floor(sim.time() / interval + 1e-9) + 1) * interval;
    }
  }
}

void runDamBreak(Row& row) {
  const auto start = Clock::now();
  const std::clock_t cpuStart = std::clock();
  const double s = row.spacing, width = s * kSlabLayers;
  Simulation sim(settingsFor(row.solver, s));
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(8 * kA), Real(width), Real(4 * kA)), false, kSlabSides));
  row.fluid = static_cast<long long>(sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(kA), Real(width), Real(2 * kA))));
  TimeSeries front, height;
  auto sample = [&] {
    const auto& positions = sim.particles().position;
    front.emplace_back(sim.time(), surgeFront(positions, Vec3r::UnitX(), Real(s)) / kA);
    height.emplace_back(sim.time(), waterHeight(positions, 0.003, 0.5 * width, Real(s)) / (2 * kA));
  };
  stepSampling(sim, kEndTime, kSampleInterval, sample);
  row.wall = secondsSince(start);
  row.cpu = double(std::clock() - cpuStart) / CLOCKS_PER_SEC;
  row.steps = double(sim.stepCount());
  row.msPerStep = 1e3 * row.wall / row.steps;
  // The tables' dimensionless times: T = t sqrt(2g/a) (surge front), tau = t sqrt(g/a) (column height).
  const double frontTimeScale = std::sqrt(2 * kStandardGravity / kA), heightTimeScale = std::sqrt(kStandardGravity / kA);
  row.frontRms = relativeRmsError(kFrontTable, frontTimeScale, front).rms;
  if (const char* dir = std::getenv("CASCADE_ACCURACY_CURVES"); dir && *dir) {
    // The probe series for convergence studies: t, Z = x/a, T = t sqrt(2g/a), H, tau.
    // The directory was created before the first run; a failed write costs this file only.
    const std::filesystem::path file =
        std::filesystem::path(dir) / (row.solver + "_" + std::to_string(int(std::lround(kA / s))) + ".dat");
    std::ofstream out(file);
    out << "# t Z T H tau\n";
    for (std::size_t k = 0; k < front.size(); ++k)
      out << front[k].first << ' ' << front[k].second << ' ' << front[k].first * frontTimeScale << ' '
          << height[k].second << ' ' << front[k].first * heightTimeScale << '\n';
    out.close();
    if (!out) std::fprintf(stderr, "bench accuracy: warning: %s: could not write the curves\n", file.string().c_str());
  }
  row.heightRms = relativeRmsError(kHeightTable, heightTimeScale, height).rms;
  // Both tables with the experiment's time origin moved by the release shift (T units).
  const double delay = releaseShift() / frontTimeScale;
  row.frontRmsRelease = relativeRmsError(kFrontTable, frontTimeScale, front, delay).rms;
  row.heightRmsRelease = relativeRmsError(kHeightTable, heightTimeScale, height, delay).rms;
}

void runHydrostatic(Row& row) {
  const auto start = Clock::now();
  const double s = row.spacing, width = s * kSlabLayers;
  Simulation sim(settingsFor(row.solver, s));
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(kA), Real(width), Real(4 * kA)), false, kSlabSides));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(kA), Real(width), Real(2 * kA)));
  const double restDensity = sim.settings().fluid.restDensity;
  const double expected = restDensity * kStandardGravity * 2 * kA;  // rho g H
  const Vec3r floorPoint(Real(0.5 * kA), Real(0.5 * width), 0);
  double pressureSum = 0, averageSum = 0, maxCompression = 0;
  int samples = 0;
  double next = kSettleTime - kSampleWindow;
  while (sim.time() < kSettleTime) {
    sim.step();
    if (sim.time() >= next) {
      const Particles& p = sim.particles();
      pressureSum += pressureAt(p, floorPoint, sim.supportRadius(), sim.settings().solver.gravity);
      double compression = 0;
      for (Real rho : p.density) {
        const double c = double(rho) / restDensity - 1.0;
        compression += std::max(c, 0.0);
        maxCompression = std::max(maxCompression, c);
      }
      averageSum += compression / double(p.size());
      ++samples;
      next += kSampleInterval;
    }
  }
  row.pressureError = std::abs(pressureSum / samples - expected) / expected;
  row.densityAvg = averageSum / samples;
  row.densityMax = maxCompression;
  row.hydroWall = secondsSince(start);
}

/// The items of an environment variable's list (`fallback` if it is unset or empty).
std::vector<std::string> listFromEnvironment(const char* name, std::vector<std::string> fallback, char separator = ',');

// Lobovsky et al. (2014), H = 300 mm: the scene, its sensor and the experiment's band.
constexpr double kLobovskyDepth = 0.3;             // m, H
constexpr double kLobovskyEndTime = 7.0;           // t / T
constexpr double kLobovskySampleInterval = 5e-4;   // s
constexpr const char* kLobovskySensor = "P2";
const char* const kLobovskyBand = "/scenes/validation/lobovsky2014_H300_sensor2_percentiles.csv";

struct ImpactRow {
  std::string solver;
  double spacing = 0;
  long long fluid = 0;
  double wall = 0, cpu = 0, steps = 0;
  BandComparison comparison;
  TimeSeries series;  // t / T, p / (rho g H)
};

void runLobovsky(ImpactRow& row, const PercentileBand& band) {
  const auto start = Clock::now();
  const std::clock_t cpuStart = std::clock();
  char spacing[32];
  std::snprintf(spacing, sizeof spacing, "%.9g", row.spacing);
  std::vector<std::string> sets = {"solver.type=" + row.solver, std::string("fluid.spacing=") + spacing};
  if (const std::string v = environmentChoice("CASCADE_ACCURACY_DENSITY", {"summation", "continuity"});
      !v.empty() && row.solver == "wcsph")
    sets.push_back("solver.density=" + v);
  for (const std::string& set : listFromEnvironment("CASCADE_ACCURACY_LOBOVSKY_SET", {}, ';')) sets.push_back(set);
  const scene::Scene scene = scene::loadScene(std::string(CASCADE_SOURCE_DIR) + "/scenes/lobovsky.json", sets);
  Simulation sim(scene::simulationSettings(scene));
  scene::setUpSimulation(scene, sim, nullptr);
  row.fluid = static_cast<long long>(sim.particles().size());
  const auto sensor = std::find_if(scene.probes.begin(), scene.probes.end(),
                                   [](const scene::Probe& p) { return p.name == kLobovskySensor; });
  if (sensor == scene.probes.end()) throw InputError("scenes/lobovsky.json: no probe named P2");
  const Vec3r at(Real(sensor->at[0]), Real(sensor->at[1]), Real(sensor->at[2]));
  const Vec3r normal(Real(sensor->normal[0]), Real(sensor->normal[1]), Real(sensor->normal[2]));
  const double g = sim.settings().solver.gravity.norm();
  const double period = std::sqrt(kLobovskyDepth / g);                            // T
  const double scale = double(sim.settings().fluid.restDensity) * g * kLobovskyDepth;  // rho g H
  const Real reach = sim.supportRadius() + Real(sensor->radius);
  auto sample = [&] {
    const NeighborLists near = probeNeighborhoods(sim.particles(), {at}, reach);
    const double p = pressureOverDisc(sim.particles(), at, normal, Real(sensor->radius), sim.supportRadius(),
                                      sim.settings().solver.gravity, near.begin(0), near.end(0));
    row.series.emplace_back(sim.time() / period, p / scale);
  };
  stepSampling(sim, kLobovskyEndTime * period, kLobovskySampleInterval, sample);
  row.wall = secondsSince(start);
  row.cpu = double(std::clock() - cpuStart) / CLOCKS_PER_SEC;
  row.steps = double(sim.stepCount());
  row.comparison = compareWithBand(row.series, band);
}

std::vector<std::string> listFromEnvironment(const char* name, std::vector<std::string> fallback, char separator) {
  const char* value = std::getenv(name);
  if (!value || !*value) return fallback;
  std::vector<std::string> items;
  std::stringstream stream(value);
  std::string item;
  while (std::getline(stream, item, separator))
    if (!item.empty()) items.push_back(item);
  return items;
}

/// Runs gnuplot on `plot` (which writes `temp`), renames temp to png (whole or not at all)
/// and removes `dir`; throws with gnuplot's first error line.
void runGnuplot(const std::string& plot, const std::filesystem::path& dir, const std::filesystem::path& temp,
                const std::filesystem::path& png);

/// gnuplot: log-log front RMS error against wall time, one line per solver.
void writePlot(const std::vector<Row>& rows, const std::filesystem::path& png) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("cascade_accuracy_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::map<std::string, std::vector<const Row*>> bySolver;
  for (const Row& r : rows) bySolver[r.solver].push_back(&r);
  std::ostringstream plot;
  if (png.has_parent_path()) std::filesystem::create_directories(png.parent_path());  // as the JSON's writer does
  const std::filesystem::path temp = png.string() + ".tmp.png";
  // pngcairo if this gnuplot has it, else the libgd png terminal.
  plot << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) { set terminal pngcairo size 900,650 enhanced font 'sans,11' }"
          " else { set terminal png size 900,650 }\n"
       << "set output '" << temp.string() << "'\n"
       << "set logscale xy\nset grid xtics ytics mxtics mytics\n"
       << "set xlabel 'wall time of the dam-break run (s)'\nset ylabel 'error (fraction)'\n"
       << "set title 'Cascade: dam break (Martin and Moyce, n^2 = 2) error against run time'\n"
       << "set key top right\nplot ";
  bool first = true;
  int style = 1;
  for (const auto& [solver, list] : bySolver) {
    const std::filesystem::path data = dir / (solver + ".dat");
    std::ofstream out(data);
    out << "# wall_s front_rms height_rms spacing front_rms_release\n";
    for (const Row* r : list)
      out << r->wall << ' ' << r->frontRms << ' ' << r->heightRms << ' ' << r->spacing << ' ' << r->frontRmsRelease << '\n';
    out.close();
    if (!first) plot << ", ";
    plot << "'" << data.string() << "' using 1:2 with linespoints lw 2 pt 7 lc " << style << " title '" << solver
         << " front RMS', '' using 1:3 with linespoints dt 2 pt 6 lc " << style << " title '" << solver
         << " column height RMS', '' using 1:5 with linespoints dt 3 pt 4 lc " << style << " title '" << solver
         << " front RMS, release shift'";
    first = false;
    ++style;
  }
  plot << "\n";
  runGnuplot(plot.str(), dir, temp, png);
}

/// gnuplot: sensor 2 against the experiment's band, raw and 5 ms averaged, one colour per run.
void writeImpactPlot(const std::vector<ImpactRow>& rows, const PercentileBand& band, const std::filesystem::path& png) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("cascade_accuracy_impact_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  if (png.has_parent_path()) std::filesystem::create_directories(png.parent_path());
  const std::filesystem::path temp = png.string() + ".tmp.png";
  {
    std::ofstream out(dir / "band.dat");
    for (std::size_t k = 0; k < band.time.size(); k += 4)  // 5 kHz of the 20 kHz band is plenty to draw
      out << band.time[k] << ' ' << band.low[k] << ' ' << band.median[k] << ' ' << band.high[k] << '\n';
  }
  std::ostringstream plot;
  plot << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) { set terminal pngcairo size 1100,650 enhanced font 'sans,11' }"
          " else { set terminal png size 1100,650 }\n"
       << "set output '" << temp.string() << "'\n"
       << "set grid\nset xrange [1.5:7]\nset xlabel 't / T,  T = sqrt(H/g)'\nset ylabel 'p / (rho g H)'\n"
       << "set title 'Lobovsky et al. (2014), H = 300 mm, sensor 2: raw probe (thin) and 5 ms average (thick)'\n"
       << "set key top right\n"
       << "plot '" << (dir / "band.dat").string()
       << "' using 1:2:4 with filledcurves fc rgb '#d0d0d0' title 'experiment 2.5-97.5 %', '' using 1:3 with lines lc "
          "rgb '#404040' lw 2 title 'experiment median'";
  int style = 1;
  for (const ImpactRow& r : rows) {
    char name[64];
    std::snprintf(name, sizeof name, "%s_%g.dat", r.solver.c_str(), r.spacing);
    const TimeSeries smooth = movingAverage(r.series, BandWindows().noiseWindow);
    std::ofstream out(dir / name);
    for (std::size_t k = 0; k < r.series.size(); ++k)
      out << r.series[k].first << ' ' << r.series[k].second << ' ' << smooth[k].second << '\n';
    char title[96];
    std::snprintf(title, sizeof title, "%s, s = %g mm", r.solver.c_str(), 1e3 * r.spacing);
    plot << ", '" << (dir / name).string() << "' using 1:2 with lines lw 0.5 lc " << style << " notitle, '' using 1:3 "
         << "with lines lw 2 lc " << style << " title '" << title << "'";
    ++style;
  }
  plot << "\n";
  runGnuplot(plot.str(), dir, temp, png);
}

void runGnuplot(const std::string& plot, const std::filesystem::path& dir, const std::filesystem::path& temp,
                const std::filesystem::path& png) {
  const std::filesystem::path script = dir / "plot.gp";
  std::ofstream(script) << plot;
  const std::string command = "gnuplot '" + script.string() + "' 2>'" + (dir / "gnuplot.log").string() + "'";
  const int status = std::system(command.c_str());
  if (status != 0 || !std::filesystem::exists(temp)) {
    std::ifstream log(dir / "gnuplot.log");
    std::string line;
    std::getline(log, line);
    std::filesystem::remove_all(dir);
    throw std::runtime_error(png.string() + ": gnuplot failed (" + line + ")");
  }
  std::filesystem::rename(temp, png);  // whole or not at all
  std::filesystem::remove_all(dir);
}

} // namespace

BenchTable benchAccuracy() {
  const std::vector<std::string> solvers = listFromEnvironment("CASCADE_ACCURACY_SOLVERS", {"wcsph", "dfsph"});
  const std::vector<std::string> resolutions =
      listFromEnvironment("CASCADE_ACCURACY_RESOLUTIONS", {"8", "12", "18", "27", "36", "54"});
  releaseShift();  // the environment is checked before minutes of runs, not after
  if (const char* dir = std::getenv("CASCADE_ACCURACY_CURVES"); dir && *dir) {
    std::error_code error;
    std::filesystem::create_directories(dir, error);
    if (error || !std::filesystem::is_directory(dir))
      throw InputError(std::string("CASCADE_ACCURACY_CURVES: cannot create directory ") + dir +
                       (error ? ": " + error.message() : std::string()));
  }
  std::vector<Row> rows;
  for (const std::string& solver : solvers) {
    if (solver != "wcsph" && solver != "dfsph") throw InputError("CASCADE_ACCURACY_SOLVERS: unknown solver '" + solver + "'");
    for (const std::string& resolution : resolutions) {
      if (resolution == "none") continue;  // the Lobovsky case alone
      const double across = std::stod(resolution);
      if (!(across >= 2 && across <= 400)) throw InputError("CASCADE_ACCURACY_RESOLUTIONS: a / s must be in [2, 400]");
      Row row;
      row.solver = solver;
      row.spacing = kA / across;
      if (!std::getenv("CASCADE_ACCURACY_TANK_ONLY")) runDamBreak(row);
      if (std::getenv("CASCADE_ACCURACY_DAMBREAK_ONLY")) {
        row.pressureError = row.densityAvg = row.densityMax = std::nan("");  // no tank run
      } else {
        runHydrostatic(row);
      }
      std::fprintf(stderr,
                   "bench accuracy: %s a/s = %g (s = %.5g m, %lld particles): dam break %.1f s wall (%.1f s CPU), %.0f steps, "
                   "%.2f ms/step, front RMS %.2f %%, height RMS %.2f %% (release shift: %.2f %%, %.2f %%); tank %.1f s "
                   "wall, floor pressure %.2f %%, compression avg %.4f %% max %.3f %%\n",
                   solver.c_str(), across, row.spacing, row.fluid, row.wall, row.cpu, row.steps, row.msPerStep,
                   100 * row.frontRms, 100 * row.heightRms, 100 * row.frontRmsRelease, 100 * row.heightRmsRelease,
                   row.hydroWall, 100 * row.pressureError,
                   100 * row.densityAvg, 100 * row.densityMax);
      rows.push_back(row);
    }
  }
  // Lobovsky et al. (2014): the shipped scene at each spacing.
  std::vector<ImpactRow> impacts;
  const std::vector<std::string> lobovskySpacings = listFromEnvironment("CASCADE_ACCURACY_LOBOVSKY", {"0.01", "0.005"});
  PercentileBand band;
  if (!(lobovskySpacings.size() == 1 && lobovskySpacings[0] == "none")) {
    band = readPercentileBand(std::string(CASCADE_SOURCE_DIR) + kLobovskyBand);
    for (const std::string& solver : solvers)
      for (const std::string& text : lobovskySpacings) {
        ImpactRow row;
        row.solver = solver;
        char* end = nullptr;
        row.spacing = std::strtod(text.c_str(), &end);
        if (*end != '\0' || !(row.spacing >= 0.001 && row.spacing <= 0.05))
          throw InputError("CASCADE_ACCURACY_LOBOVSKY: '" + text + "' is not a spacing in [0.001, 0.05] m");
        runLobovsky(row, band);
        const BandComparison& c = row.comparison;
        std::fprintf(stderr,
                     "bench accuracy: lobovsky %s s = %g m (%lld particles): %.1f s wall (%.1f s CPU), %.0f steps; "
                     "first peak (5 ms average) %.3f at t/T %.3f (median %.3f at %.3f): %+.1f %%, %+.3f T; raw "
                     "%.3f at %.3f (%+.1f %%); in band %.1f %%; noise %.3f rho g H\n",
                     solver.c_str(), row.spacing, row.fluid, row.wall, row.cpu, row.steps, c.peak.value, c.peak.time,
                     c.reference.value, c.reference.time, 100 * c.peakError, c.peakTimeError, c.rawPeak.value,
                     c.rawPeak.time, 100 * c.rawPeakError, 100 * c.bandFraction, c.noise);
        impacts.push_back(std::move(row));
      }
  }
  const double none = std::nan("");
  BenchTable table("accuracy", {"case", "solver", "spacing", "n_fluid", "wall_s", "front_rms", "height_rms",
                                "pressure_err", "density_err_avg", "density_err_max", "cpu_s", "steps",
                                "front_rms_release", "height_rms_release", "peak_err", "peak_time_err",
                                "band_fraction", "noise", "peak_err_raw"});
  for (const Row& r : rows)
    table.addRow({std::string("dambreak"), r.solver, r.spacing, r.fluid, r.wall, r.frontRms, r.heightRms,
                  r.pressureError, r.densityAvg, r.densityMax, r.cpu, static_cast<long long>(r.steps),
                  r.frontRmsRelease, r.heightRmsRelease, none, none, none, none, none});
  for (const ImpactRow& r : impacts)
    table.addRow({std::string("lobovsky"), r.solver, r.spacing, r.fluid, r.wall, none, none, none, none, none, r.cpu,
                  static_cast<long long>(r.steps), none, none, r.comparison.peakError, r.comparison.peakTimeError,
                  r.comparison.bandFraction, r.comparison.noise, r.comparison.rawPeakError});
  const BenchPaths& paths = benchPaths();
  std::filesystem::path png;
  if (!paths.plot.empty())
    png = paths.plot;
  else if (!paths.json.empty())
    png = std::filesystem::path(paths.json).replace_extension(".png");
  if (!png.empty())
    table.setFinish([rows, impacts, band, png] {
      if (!rows.empty()) {
        writePlot(rows, png);
        std::fprintf(stderr, "bench accuracy: plot written to %s\n", png.string().c_str());
      }
      if (!impacts.empty()) {
        std::filesystem::path impactPng = png;
        impactPng.replace_filename(png.stem().string() + "-lobovsky" + png.extension().string());
        writeImpactPlot(impacts, band, impactPng);
        std::fprintf(stderr, "bench accuracy: plot written to %s\n", impactPng.string().c_str());
      }
    });
  return table;
}

} // namespace cascade::cli
