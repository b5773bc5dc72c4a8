/// @file Scene.h
/// @brief The scene model (JSON, SI units, z up; README "Scenes"):
///        fluid (blocks, emitters), solver settings, boundaries, output,
///        camera, lights and probes, as plain data with every default filled in.
///
/// The JSON form, its validation and the `--set` overrides live in
/// SceneJson.h; this header only holds the values. Field names follow the
/// JSON keys (snake_case in JSON, camelCase here). All lengths in metres,
/// times in seconds, angles in degrees.
#pragma once

#include "libsph/Types.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace cascade::scene {

using Vec3 = std::array<double, 3>;

/// An axis-aligned box [min, max].
struct Box {
  Vec3 min{0, 0, 0};
  Vec3 max{0, 0, 0};
};

/// A block of fluid on a regular lattice of the fluid spacing, at a start velocity.
struct FluidBlock {
  Box box;
  Vec3 velocity{0, 0, 0};
};

/// A nozzle: a disk (radius) or rectangle (size = [width, height]) at
/// `center`, facing `normal`, that emits layers of particles on the fluid
/// lattice at `speed` along the normal between `start` and `end`, up to
/// `maxCount` particles (0: no limit). `rate` (particles/s) is derived from
/// speed * area / spacing^3 when 0.
struct Emitter {
  std::string name;
  std::string shape = "disk";  ///< "disk" | "rectangle"
  Vec3 center{0, 0, 0};
  Vec3 normal{1, 0, 0};
  Vec3 up{0, 0, 1};            ///< rectangle: direction of its height (projected onto the nozzle plane)
  double radius = 0.05;        ///< disk
  std::array<double, 2> size{0.1, 0.1};  ///< rectangle: width, height
  double speed = 1.0;          ///< m/s along normal
  double rate = 0;             ///< particles per second; 0 = speed * area / spacing^3
  double start = 0;            ///< s
  double end = 1e30;           ///< s
  std::int64_t maxCount = 0;   ///< 0: no limit
};

struct Fluid {
  double spacing = 0.02;       ///< initial particle spacing, m
  double density = 1000;       ///< rest density rho_0, kg/m^3
  double viscosity = 0.0;      ///< dynamic viscosity mu of SEED (6), Pa s; 0 skips the pass
  std::vector<FluidBlock> blocks;
  std::vector<Emitter> emitters;
};

/// Solver settings; mapped onto libsph/solver/SolverSettings.h (the same
/// meaning and defaults; 0 for a derived value means "derive it").
struct Solver {
  std::string type = "wcsph";        ///< see solverTypes() in SceneJson.h
  std::string eos = "linear";        ///< "linear" SEED (10) | "tait"
  double stiffness = 0;              ///< k of SEED (10), m^2/s^2; 0: (10 expected_speed)^2
  double taitExponent = 7;
  bool clampNegativePressure = true;
  /// WCSPH density / pressure-gradient kernels: "auto" (cubic_spline when a rigid
  /// body floats, else wendland_c2) | "wendland_c2" | "cubic_spline" | "mueller2003"
  /// (the SEED's poly6 / spiky pair)
  std::string kernels = "auto";
  /// WCSPH pressure force: "hamiltonian" (Monaghan 1992) | "symmetric" | "mueller_half" (SEED (5) as printed)
  std::string pressureForce = "hamiltonian";
  bool surfaceLayerPressure = true;  ///< WCSPH: top layer keeps rho_0 |g| s / 2
  std::string density = "summation"; ///< WCSPH: "summation" SEED (4) | "continuity" (with density diffusion)
  double densityDiffusion = 0.1;     ///< WCSPH continuity: delta-SPH's delta (0 = off)
  double velocityFilter = 0;         ///< WCSPH: bi-Laplacian velocity filter beta (0 = off)
  double artificialViscosity = 0.1;  ///< Monaghan alpha; 0 = off
  bool artificialViscosityAllPairs = true;  ///< WCSPH: also for receding pairs
  double expectedSpeed = 0;          ///< m/s; 0: derived (free fall height, emitter speeds)
  double instabilitySpeedFactor = 20;
  double densityTolerance = 0.0005;  ///< dfsph
  double divergenceTolerance = 0.0002;///< dfsph (SolverSettings.h)
  std::int64_t maxIterations = 300;  ///< dfsph (SolverSettings.h)
  std::string preconditioner = "two_level";  ///< dfsph: two_level, jacobi
  double particleToleranceShare = 0;        ///< dfsph (SolverSettings.h); 0: by preconditioner
  double supportFactor = 0;          ///< support radius h = support_factor * spacing; 0: the solver's own
  double cfl = 0.4;
  double dtMin = 1e-6;
  double dtMax = 5e-3;
  std::string neighborSearch = "grid";
  std::int64_t reorderInterval = 25;
  // Virtual boundary particles (SEED section 2.2)
  bool repulsionParticles = true;    ///< type I
  bool mirrorParticles = true;       ///< type II
  bool mirrorHydrostatic = false;    ///< BoundarySettings::mirrorHydrostatic
  double repulsion = 0;              ///< D of SEED (11), m^2/s^2; 0: expected_speed^2
  double repulsionRadius = 0;        ///< r0 of SEED (11), m; 0: the fluid spacing
  double sampleGap = 0.5;            ///< largest type I gap as a fraction of r0
  std::string slip = "free";         ///< mirror velocity: "free" | "no" | "laminar" (free + laminar wall shear, DFSPH)
  double kappa = 1;                  ///< mirrors within kappa h of a wall
};

/// An infinite plane through `point` with the fluid on the side `normal` points to.
struct Plane {
  Vec3 point{0, 0, 0};
  Vec3 normal{0, 0, 1};
};

/// A finite inclined slab: a box of size [length, width, thickness] centred at
/// `center`, rotated by `angle` degrees about the axis `axis` (a ramp).
/// Water runs on its top face.
struct Slope {
  std::string name;
  Vec3 center{0, 0, 0};
  std::array<double, 3> size{1, 1, 0.02};
  Vec3 axis{0, 1, 0};
  double angle = 0;
};

/// One key of a keyframed motion (docs/moving-solids.md): at time t the
/// obstacle is moved by `translate` and turned by `rotate` (degrees about x, then y,
/// then z) about the mesh's own origin (its placed `translate`), on top of its
/// placement.
struct Keyframe {
  double t = 0;
  Vec3 translate{0, 0, 0};
  Vec3 rotate{0, 0, 0};
};

/// A piston wavemaker: displacement (stroke / 2) sin(2 pi t / period) along `axis`,
/// the amplitude ramped up over `ramp` seconds.
struct Piston {
  Vec3 axis{1, 0, 0};
  double stroke = 0.1;
  double period = 1;
  double ramp = 0;
};

/// A prescribed (kinematic) motion: keyframes or a piston, exactly one.
struct Motion {
  std::vector<Keyframe> keyframes;
  std::optional<Piston> piston;
};

/// A rigid body that water and gravity move (two-way coupling): its density
/// (mass from the closed mesh's volume) or its mass, one of the two.
struct Dynamic {
  double density = 0;   ///< kg/m^3; 0: use mass
  double mass = 0;      ///< kg; 0: use density
  double friction = 0.4;     ///< Coulomb friction against other solids
  double restitution = 0.0;  ///< normal restitution against other solids
};

/// A mesh obstacle: file (absolute once resolved), transform applied as
/// scale, then rotate (Euler XYZ degrees), then translate; simplified to
/// `triangles` (0: as loaded). It stands still, moves as prescribed (`motion`),
/// or is a rigid body (`dynamic`); at most one of the two.
struct Obstacle {
  std::string name;
  std::string mesh;
  Vec3 translate{0, 0, 0};
  Vec3 rotate{0, 0, 0};
  double scale = 1;
  std::int64_t triangles = 0;
  std::optional<Motion> motion;
  std::optional<Dynamic> dynamic;

  /// True if `mesh` is a deforming sequence: a run of '#' in its file name stands for
  /// the frame number ("assets/paddle.####.obj").
  bool isSequence() const { return mesh.find('#', mesh.find_last_of('/') + 1) != std::string::npos; }
};

struct Boundaries {
  std::optional<Box> tank;              ///< open-top box: floor and four walls
  std::vector<Plane> planes;
  std::vector<Slope> slopes;
  std::vector<Obstacle> obstacles;
  std::optional<Box> domain;            ///< particles leaving it are removed
  std::vector<Box> kill;                ///< particles entering one are removed
};

struct Output {
  double fps = 30;
  double endTime = 2;
  double probeRate = 100;               ///< probe samples per simulated second
  int frameCount() const;               ///< frames 1..N at t = k / fps
};

struct Camera {
  Vec3 position{2, -2, 1.5};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 0, 1};
  double fov = 45;                      ///< vertical, degrees
};

/// Mesh adaptivity by default: flat water merged within 0.45 voxel of the uniform mesh
/// (3.9-6.8x fewer triangles on the dam break's frames), and the uniform mesh where
/// merging would not cut it 1.5x (a splash), found for about 1 % of the stage. At 0.2
/// a ball of 20 voxels' radius needs so many repairs that it gets its uniform mesh
/// (docs/shot-outputs.md).
constexpr double kDefaultMeshAdaptivity = 0.1;

/// What `cascade surface OUT` does by default (it reads them from OUT/scene.json;
/// its command-line options override them). Names as the CLI's.
struct SurfaceSettings {
  std::string method = "anisotropic";  ///< "union" | "smooth" | "anisotropic"
  std::string meshFormat = "obj";      ///< "obj" | "ply"
  std::string outputs = "both";        ///< "both" | "vdb" | "mesh"
  bool velocity = true;                ///< the "v" grid and per-vertex mesh velocities
  double adaptivity = kDefaultMeshAdaptivity;  ///< mesh adaptivity in [0, 1]
  std::string meshUp = "y";            ///< axes of the mesh file: "y" (for importers) | "z" (scene)
  bool foamDensity = false;            ///< a "foam" fog grid in the VDB, from the whitewater stage
};

/// The whitewater stage (Ihmsen, Akinci, Akinci & Teschner 2012, "Unified spray,
/// foam and bubbles for particle-based fluids"): what `cascade whitewater OUT`
/// does by default (read from OUT/scene.json; its options override). A scene
/// without a "whitewater" block has no whitewater stage in `cascade run`.
/// docs/whitewater.md says what each value does and where its default comes from.
struct WhitewaterSettings {
  /// "auto": the clamping ranges come from the bake's own statistics (the mean
  /// of each potential's per-frame maxima, M, gives [0.1 M, M], with physical
  /// floors); "fixed": the ranges below.
  std::string limits = "auto";
  std::array<double, 2> trappedAir{5, 20};      ///< [tau_min, tau_max] of the trapped-air potential, m/s
  std::array<double, 2> waveCrest{0.5, 2};      ///< [tau_min, tau_max] of the wave-crest potential
  std::array<double, 2> kineticEnergy{5, 50};   ///< [tau_min, tau_max] of the kinetic energy per mass, J/kg
  double trappedAirRate = 1000;   ///< k_ta: births per second of a fluid particle at full potentials
  double waveCrestRate = 1000;    ///< k_wc
  double rateScale = 1;           ///< multiplies both rates (the artist's knob)
  /// "particle" (the paper): the rates are per fluid particle. "area" or
  /// "volume": they are those of a bake at referenceSpacing, and a bake at
  /// spacing s gives each fluid particle (s / referenceSpacing)^2 or ^3 of them:
  /// the same births per area of water surface, or per litre of water, at any
  /// resolution (docs/whitewater.md measures both).
  std::string ratesPer = "particle";
  double referenceSpacing = 0;    ///< m; needed by, and only by, "area" and "volume"
  std::array<double, 2> lifetime{2, 5};  ///< foam lifetime range, s (each particle draws one)
  int sprayNeighbors = 6;         ///< fewer fluid neighbours: spray
  int bubbleNeighbors = 20;       ///< more fluid neighbours: a bubble; between: foam
  double buoyancy = 2;            ///< k_b: bubble buoyancy, in units of |g|
  double bubbleDrag = 40;         ///< k_d: pull of a bubble to the fluid velocity, 1/s
  double airDrag = 0.5;           ///< spray's pull to still air, 1/s (0: ballistic)
  int substeps = 0;               ///< per frame interval; 0: from the fluid's speed
  std::int64_t seed = 0;          ///< random stream; the same seed gives the same particles
  bool ply = false;               ///< also OUT/whitewater/whitewater.NNNN.ply (Blender reads PLY)
};

struct Light {
  std::string type = "directional";     ///< "directional" | "point"
  Vec3 direction{-0.3, 0.4, -1};        ///< directional: the way the light travels
  Vec3 position{0, 0, 3};               ///< point
  Vec3 color{1, 1, 1};
  double intensity = 1;
};

/// A probe of a scene (README "Scenes"). Fields unused by a type keep their defaults.
struct Probe {
  std::string name;
  std::string type;                     ///< "height" | "pressure" | "force" | "front" | "body" | "velocity"
  Vec3 at{0, 0, 0};                     ///< height: x, y (z ignored); pressure, velocity: x, y, z
  std::string obstacle;                 ///< force, body
  Vec3 direction{1, 0, 0};              ///< front
  /// pressure: the sensor face's radius, m (0: a point); its normal (zero: the normal of
  /// the tank wall the point lies on)
  double radius = 0;
  Vec3 normal{0, 0, 0};
};

struct Scene {
  std::string name = "scene";
  std::string description;
  std::string size = "production";      ///< the preset applied (see SceneJson.h)
  Vec3 gravity{0, 0, -9.81};
  Fluid fluid;
  Solver solver;
  Boundaries boundaries;
  Output output;
  SurfaceSettings surface;
  std::optional<WhitewaterSettings> whitewater;  ///< absent: no whitewater stage
  Camera camera;
  std::vector<Light> lights;
  std::vector<Probe> probes;
};

} // namespace cascade::scene
