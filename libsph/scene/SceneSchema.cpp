#include "libsph/scene/SceneSchema.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

namespace cascade::scene {

using nlohmann::json;

namespace {

/// A scene that takes every branch of the parser: one item of every array, each
/// probe type, both motions, a rigid body, every optional block.
const char* const kEveryBranch = R"({
  "name": "every_key", "description": "", "size": "production", "gravity": [0, 0, -9.81],
  "fluid": {
    "blocks": [{"min": [0, 0, 0], "max": [0.2, 0.2, 0.2]}],
    "emitters": [{"shape": "rectangle", "center": [0.5, 0.5, 0.5], "normal": [1, 0, 0], "up": [0, 0, 1]}]
  },
  "solver": {},
  "boundaries": {
    "tank": {"min": [0, 0, 0], "max": [1, 1, 1]},
    "planes": [{"point": [0, 0, 0]}],
    "slopes": [{"center": [0.5, 0.5, 0.1], "size": [0.4, 0.4, 0.02]}],
    "obstacles": [
      {"name": "keyed", "mesh": "keyed.obj", "motion": {"keyframes": [{"t": 0}]}},
      {"name": "piston", "mesh": "piston.obj", "motion": {"piston": {}}},
      {"name": "floating", "mesh": "floating.obj", "dynamic": {"density": 500}}
    ],
    "domain": {"min": [-1, -1, -1], "max": [2, 2, 2]},
    "kill": [{"min": [-1, -1, -1], "max": [2, 2, -0.5]}]
  },
  "output": {}, "surface": {}, "whitewater": {}, "camera": {}, "lights": [{}],
  "probes": [
    {"name": "h", "type": "height", "at": [0.5, 0.5]},
    {"name": "p", "type": "pressure", "at": [0, 0.5, 0.1], "radius": 0.005, "normal": [1, 0, 0]},
    {"name": "u", "type": "velocity", "at": [0.5, 0.5, 0.1]},
    {"name": "f", "type": "force", "obstacle": "keyed"},
    {"name": "b", "type": "body", "obstacle": "floating"},
    {"name": "x", "type": "front"}
  ]
})";

/// Units and meanings: one entry per key the parser reads (SceneSchema.h).
struct KeyDoc {
  const char* path;
  const char* unit;
  const char* description;
  const char* defaultText = "";  ///< replaces the default the parser was given, when that is not the rule
};

const std::vector<KeyDoc>& keyDocs() {
  static const std::vector<KeyDoc> docs{
      {"name", "", "The scene's name: the default output folder is out/NAME; no '/'."},
      {"description", "", "Free text about the scene."},
      {"size", "", "The preset to apply (a key of \"presets\")."},
      {"presets", "", "Named sets of overrides: {\"seed\": {\"fluid.spacing\": 0.02, ...}, ...}; a value the file sets itself wins."},
      {"gravity", "m/s^2", "Gravitational acceleration; its length at most 1e3."},
      {"fluid", "", "The water: its lattice spacing, material, and where it starts or enters."},
      {"fluid.spacing", "m", "Particle spacing of the initial lattice (r0 of SEED section 1); sets the particle count and the support radius."},
      {"fluid.density", "kg/m^3", "Rest density rho_0."},
      {"fluid.viscosity", "Pa s", "Dynamic viscosity mu of SEED (6) (water: 0.001); 0 skips the viscosity pass."},
      {"fluid.blocks", "", "Boxes filled with fluid on the lattice at the start."},
      {"fluid.blocks[].min", "m", "Lower corner of the box."},
      {"fluid.blocks[].max", "m", "Upper corner; above min in every axis."},
      {"fluid.blocks[].velocity", "m/s", "Initial velocity of the block's particles."},
      {"fluid.emitters", "", "Nozzles that add fluid while the bake runs."},
      {"fluid.emitters[].name", "", "Name in the log.", "`emitterN` (N from 1)"},
      {"fluid.emitters[].shape", "", "Nozzle outline: a disk of `radius` or a rectangle of `size`."},
      {"fluid.emitters[].center", "m", "Centre of the nozzle."},
      {"fluid.emitters[].normal", "", "Direction the fluid leaves in (not zero; normalised)."},
      {"fluid.emitters[].up", "", "Rectangle: the direction of its height, projected onto the nozzle plane; not parallel to normal."},
      {"fluid.emitters[].radius", "m", "Disk radius."},
      {"fluid.emitters[].size", "m", "Rectangle width and height."},
      {"fluid.emitters[].speed", "m/s", "Exit speed along the normal."},
      {"fluid.emitters[].rate", "particles/s", "Particles per second; 0: speed x area / spacing^3."},
      {"fluid.emitters[].start", "s", "Time the nozzle opens."},
      {"fluid.emitters[].end", "s", "Time it closes; after start.", "never"},
      {"fluid.emitters[].max_count", "", "Most particles it emits; 0: no limit."},
      {"solver", "", "The time-step strategy and its numerics (docs/solvers.md)."},
      {"solver.type", "", "`wcsph`: weakly compressible, SEED (10); `dfsph`: divergence-free SPH (Bender & Koschier 2015)."},
      {"solver.eos", "", "WCSPH equation of state: `linear` SEED (10), or `tait` (Monaghan 1994)."},
      {"solver.stiffness", "m^2/s^2", "k of SEED (10), the squared speed of sound; 0: (10 x expected speed)^2."},
      {"solver.tait_exponent", "", "gamma of Tait's equation."},
      {"solver.clamp_negative_pressure", "", "WCSPH: p = max(p, 0), no tensile pull at the free surface."},
      {"solver.kernels", "", "WCSPH density and pressure-gradient kernels. `auto`: `cubic_spline` when a rigid body floats (the Wendland C2 lattice holds a floating body off its draft), else `wendland_c2`; `mueller2003` is the SEED's poly6 / spiky pair."},
      {"solver.pressure_force", "", "WCSPH pressure force: `hamiltonian` (Monaghan 1992), `symmetric`, or SEED (5) as printed (`mueller_half`)."},
      {"solver.surface_layer_pressure", "", "WCSPH summation density: the top particle layer keeps the pressure rho_0 g spacing / 2 instead of 0."},
      {"solver.density", "", "WCSPH density: `summation`, SEED (4), or `continuity` (integrated, with density diffusion)."},
      {"solver.density_diffusion", "", "WCSPH continuity: delta of delta-SPH's density diffusion (Molteni & Colagrossi 2009); 0: off."},
      {"solver.velocity_filter", "", "WCSPH: strength beta of the bi-Laplacian velocity filter, a -= beta c_0 / h L(L(v)): it damps particle-scale velocity and leaves smooth flow alone. Set it (0.12, as scenes/wavemaker.json) with continuity density at a support beyond 2.2 spacings, where still water is otherwise unstable and waves lose to the particle scale (docs/solvers.md, \"Still water set for waves\"); 0: off."},
      {"solver.artificial_viscosity", "", "Monaghan (1992) artificial viscosity alpha; 0: off."},
      {"solver.artificial_viscosity_all_pairs", "", "WCSPH: artificial viscosity also for receding pairs, not only approaching ones."},
      {"solver.expected_speed", "m/s", "The largest speed the scene should reach; 0: free-fall speed over the scene's height, or the largest initial or emitted speed. Sets the default stiffness, repulsion and instability threshold."},
      {"solver.instability_speed_factor", "", "A particle faster than this many expected speeds (or not finite) stops the bake with exit 3."},
      {"solver.density_tolerance", "", "DFSPH: largest mean relative density error of the pressure solve."},
      {"solver.divergence_tolerance", "", "DFSPH: largest mean relative density change per step of the divergence-free solve."},
      {"solver.max_iterations", "", "DFSPH: most sweeps of each solve per step."},
      {"solver.particle_tolerance_share", "", "DFSPH constant-density solve: the largest predicted compression of any one particle, as a share of density_tolerance (the mean alone is diluted by depth); 0: 0.2 with `two_level`, 0.02 with `jacobi`, the largest that hold a 200-layer column at rest (docs/dfsph-deep-water.md, \"Two levels\")."},
      {"solver.preconditioner", "", "DFSPH constant-density solve: `two_level` (Jacobi plus a coarse correction on cells of 2 support radii), or `jacobi` alone. With their default per-particle bounds, `two_level` bakes the 59.5 k dam break 24 % faster and a resting 200-layer column 3.3x faster, with the same Martin & Moyce errors (docs/dfsph-deep-water.md, \"Two levels\"). Over MPI ranks the solve is `jacobi`."},
      {"solver.support_factor", "", "Support radius h = support_factor x spacing. WCSPH's 2.15: at 2 its resting Wendland C2 lattice is rigid in shear, and waves run 15 % short of their period (docs/solvers.md, \"Gravity waves\").", "2.15 (wcsph), 2 (dfsph)"},
      {"solver.cfl", "", "CFL factor: dt = cfl h / (c + v_max), also bounded by viscosity and force."},
      {"solver.dt_min", "s", "Smallest time step."},
      {"solver.dt_max", "s", "Largest time step; at least dt_min."},
      {"solver.neighbor_search", "", "Neighbour search structure: a uniform grid or the SEED's octree."},
      {"solver.reorder_interval", "steps", "Steps between Morton reorders of the particles (memory locality); 0: never."},
      {"solver.repulsion_particles", "", "Type I boundary particles: the SEED (11) repulsion of mesh and wall samples."},
      {"solver.mirror_particles", "", "Type II boundary particles: mirror images across walls (Libersky & Petschke 1993)."},
      {"solver.mirror_hydrostatic", "", "WCSPH: mirror images carry their source's pressure plus rho_0 g . (image - source), their hydrostatic part (Adami et al. 2012), so the images alone hold the water's weight off the floor. For scenes without type I particles (`repulsion_particles` false), where without it the floor layer sinks to the guard's quarter spacing (docs/solvers.md, \"Gravity waves\")."},
      {"solver.repulsion", "m^2/s^2", "D of SEED (11); 0: expected speed squared."},
      {"solver.repulsion_radius", "m", "r0 of SEED (11); 0: half the fluid spacing."},
      {"solver.sample_gap", "", "Largest gap between type I samples, as a fraction of r0."},
      {"solver.slip", "", "Wall velocity of mirror particles: `free` slip, `no` slip, or free slip plus a `laminar` wall shear stress (DFSPH)."},
      {"solver.kappa", "", "Mirror particles are made for fluid within kappa x h of a wall."},
      {"boundaries", "", "The solids: tank, planes, slopes, mesh obstacles, and where particles are removed."},
      {"boundaries.tank", "",
       "An open-top box: floor and four walls, the fluid inside. A thin slab (a 2-D flume) must be at least the "
       "support radius less a spacing wide (the bake warns otherwise: docs/moving-solids.md, \"A slab's far wall\")."},
      {"boundaries.tank.min", "m", "Lower corner of the tank."},
      {"boundaries.tank.max", "m", "Upper corner (the walls' top); above min in every axis."},
      {"boundaries.planes", "", "Infinite planes."},
      {"boundaries.planes[].point", "m", "A point of the plane."},
      {"boundaries.planes[].normal", "", "The side the fluid is on (not zero)."},
      {"boundaries.slopes", "", "Inclined slabs (ramps); water runs on their top face."},
      {"boundaries.slopes[].name", "", "Name in the log.", "`slopeN` (N from 1)"},
      {"boundaries.slopes[].center", "m", "Centre of the slab."},
      {"boundaries.slopes[].size", "m", "Length, width and thickness of the slab before it is turned."},
      {"boundaries.slopes[].axis", "", "The axis it is turned about (not zero)."},
      {"boundaries.slopes[].angle", "degrees", "The angle it is turned by."},
      {"boundaries.obstacles", "", "Mesh solids (OBJ, PLY, STL and what assimp reads): still, moving, deforming or floating (docs/moving-solids.md)."},
      {"boundaries.obstacles[].name", "", "Name for probes and the log; unique.", "`obstacleN` (N from 1)"},
      {"boundaries.obstacles[].mesh", "", "Mesh file, relative to the scene file. A run of # in the file name is the frame number of a deforming sequence (one file per frame)."},
      {"boundaries.obstacles[].mesh_hash", "", "Written into OUT/scene.json: the hash of the mesh bytes the bake saw; not checked when read."},
      {"boundaries.obstacles[].translate", "m", "Placement: moved by this after scaling and turning."},
      {"boundaries.obstacles[].rotate", "degrees", "Placement: turned about x, then y, then z."},
      {"boundaries.obstacles[].scale", "", "Placement: uniform scale, applied first."},
      {"boundaries.obstacles[].triangles", "", "Simplify the mesh to this many triangles (CGAL edge collapse); 0: as loaded."},
      {"boundaries.obstacles[].motion", "", "A prescribed motion: `keyframes` or `piston`, one of the two; not with `dynamic`."},
      {"boundaries.obstacles[].dynamic", "", "A rigid body moved by water and gravity (two-way coupling, Akinci et al. 2012); the mesh must be closed unless a mass is given."},
      {"boundaries.obstacles[].motion.keyframes", "", "Keys in increasing time; linear in translation, slerp in rotation; the nearest key holds outside them."},
      {"boundaries.obstacles[].motion.piston", "", "A piston wavemaker: (stroke / 2) sin(2 pi t / period) along axis."},
      {"boundaries.obstacles[].motion.keyframes[].t", "s", "Time of the key."},
      {"boundaries.obstacles[].motion.keyframes[].translate", "m", "Move at that time, on top of the placement."},
      {"boundaries.obstacles[].motion.keyframes[].rotate", "degrees", "Turn at that time about the placed mesh origin, about x, then y, then z."},
      {"boundaries.obstacles[].motion.piston.axis", "", "Direction of the stroke (not zero)."},
      {"boundaries.obstacles[].motion.piston.stroke", "m", "Peak-to-peak travel S."},
      {"boundaries.obstacles[].motion.piston.period", "s", "Period T."},
      {"boundaries.obstacles[].motion.piston.ramp", "s", "The amplitude grows from 0 over this time."},
      {"boundaries.obstacles[].dynamic.density", "kg/m^3", "Body density: mass and inertia from the closed mesh. Give density or mass.", "one of density, mass"},
      {"boundaries.obstacles[].dynamic.mass", "kg", "Body mass, inertia from the mesh's shape. Give density or mass.", "one of density, mass"},
      {"boundaries.obstacles[].dynamic.friction", "", "Coulomb friction against other solids."},
      {"boundaries.obstacles[].dynamic.restitution", "", "Normal restitution against other solids."},
      {"boundaries.domain", "", "Particles leaving this box are removed (and counted)."},
      {"boundaries.domain.min", "m", "Lower corner."},
      {"boundaries.domain.max", "m", "Upper corner."},
      {"boundaries.kill", "", "Boxes that remove particles entering them (drains)."},
      {"boundaries.kill[].min", "m", "Lower corner."},
      {"boundaries.kill[].max", "m", "Upper corner."},
      {"output", "", "Frames and probe samples."},
      {"output.fps", "1/s", "Frames per second of the particle caches (and of every later stage)."},
      {"output.end_time", "s", "Simulated time of the last frame; at most 100000 frames."},
      {"output.probe_rate", "1/s", "Probe samples per simulated second (OUT/probes.csv). A sample between two steps is interpolated linearly from the probes at both; probes never shorten a step, so the rate changes probes.csv and nothing else."},
      {"surface", "", "What `cascade surface` does by default; its options override (docs/surfacing.md)."},
      {"surface.method", "", "Level set from particles: `union` of spheres, `smooth` (Zhu & Bridson 2005), or `anisotropic` (Yu & Turk 2013)."},
      {"surface.mesh_format", "", "Mesh file format: ASCII OBJ or binary PLY with velocities."},
      {"surface.outputs", "", "Write the level set VDB, the mesh, or `both`."},
      {"surface.velocity", "", "A velocity grid \"v\" in the VDB and per-vertex velocities in PLY meshes (motion blur)."},
      {"surface.adaptivity", "", "Mesh adaptivity (OpenVDB volumeToMesh, within 0.45 voxel of the uniform mesh; the uniform mesh where merging would not cut it 1.5x): 0 uniform, up to 1 fewest triangles on flat water."},
      {"surface.mesh_up", "", "Up axis written in mesh files: `y` for importers (Blender, Houdini), `z` as the scene."},
      {"surface.foam_density", "", "Also a \"foam\" fog grid in the VDB, from the whitewater stage."},
      {"whitewater", "", "Spray, foam and bubbles (Ihmsen et al. 2012) from the caches; `{}` takes every default (docs/whitewater.md). Absent: no whitewater stage."},
      {"whitewater.limits", "", "Clamping ranges of the potentials: `auto` from the bake's statistics, or `fixed` as below."},
      {"whitewater.trapped_air", "m/s", "[min, max] of the trapped-air potential; min < max."},
      {"whitewater.wave_crest", "", "[min, max] of the wave-crest potential; min < max."},
      {"whitewater.kinetic_energy", "J/kg", "[min, max] of the kinetic energy potential; min < max."},
      {"whitewater.trapped_air_rate", "1/s", "Births per second of a fluid particle at full trapped-air potential (k_ta)."},
      {"whitewater.wave_crest_rate", "1/s", "Births per second of a fluid particle at full wave-crest potential (k_wc)."},
      {"whitewater.rate_scale", "", "Multiplies both birth rates: the artist's knob."},
      {"whitewater.rates_per", "", "What the rates are per: `particle` (the paper), or per `area` of water surface or `volume` of water at reference_spacing (a bake at spacing s gives each particle (s / reference_spacing)^2 or ^3 of them)."},
      {"whitewater.reference_spacing", "m", "The particle spacing the rates are for, with rates_per `area` or `volume` (and only then)."},
      {"whitewater.lifetime", "s", "[min, max] lifetime of a foam particle; each draws one."},
      {"whitewater.spray_neighbors", "", "Fewer fluid neighbours than this: spray."},
      {"whitewater.bubble_neighbors", "", "More than this: a bubble; between: foam. At least spray_neighbors."},
      {"whitewater.buoyancy", "g", "Bubble buoyancy k_b, in units of the length of gravity."},
      {"whitewater.bubble_drag", "1/s", "Pull of a bubble to the fluid velocity (k_d)."},
      {"whitewater.air_drag", "1/s", "Pull of spray to still air; 0: ballistic."},
      {"whitewater.substeps", "", "Advection substeps per frame interval, at most 1000; 0: from the fluid's speed."},
      {"whitewater.seed", "", "Random stream; the same seed gives the same particles."},
      {"whitewater.ply", "", "Also write PLY points (Blender reads PLY, not VDB points)."},
      {"camera", "", "The preview camera of `cascade render`."},
      {"camera.position", "m", "Eye position."},
      {"camera.target", "m", "Point looked at; not the position."},
      {"camera.up", "", "Up direction of the image (not zero)."},
      {"camera.fov", "degrees", "Vertical field of view."},
      {"lights", "", "Preview lights.", "a key light from above and a dim fill"},
      {"lights[].type", "", "`directional` or `point`."},
      {"lights[].direction", "", "Directional: the way the light travels (not zero)."},
      {"lights[].position", "m", "Point light position."},
      {"lights[].color", "", "Linear RGB, each >= 0."},
      {"lights[].intensity", "", "Brightness factor."},
      {"probes", "", "Measurements written to OUT/probes.csv at output.probe_rate: header `t,NAME...`, one row per sample."},
      {"probes[].name", "", "Column name; unique, without commas, quotes or newlines."},
      {"probes[].type", "", "`height`: water height at x, y; `pressure` on a wall point or sensor disc; `force` of the fluid on an obstacle; `front`: furthest fluid along a direction; `body`: a moving obstacle's centre of mass and velocity; `velocity`: fluid velocity at a point."},
      {"probes[].at", "m", "height: [x, y]; pressure, velocity: [x, y, z].", "required by height, pressure, velocity"},
      {"probes[].obstacle", "", "force, body: the obstacle's name (body: one that moves).", "required by force, body"},
      {"probes[].direction", "", "front: the direction measured along (not zero)."},
      {"probes[].radius", "m", "pressure: radius of the sensor's face, averaged over (7-point disc rule); 0: a point."},
      {"probes[].normal", "", "pressure: the sensor face's normal; absent: that of the tank wall within two spacings.", "the tank wall's"},
  };
  return docs;
}

std::string formatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

} // namespace

const std::vector<SceneKey>& sceneKeys() {
  static const std::vector<SceneKey> keys = [] {
    std::vector<SceneKey> read = keysReadFrom(json::parse(kEveryBranch), ".");
    // An array's items are described by the array and their keys.
    read.erase(std::remove_if(read.begin(), read.end(),
                              [](const SceneKey& k) { return k.path.size() > 2 && k.path.substr(k.path.size() - 2) == "[]"; }),
               read.end());
    SceneKey presets;
    presets.path = "presets";
    presets.kind = "object";
    read.insert(read.begin() + 3, presets);
    std::string undocumented, unread;
    for (SceneKey& key : read) {
      if (key.kind == "any") throw std::logic_error("scene key " + key.path + " is found but never typed");
      const auto doc = std::find_if(keyDocs().begin(), keyDocs().end(),
                                    [&](const KeyDoc& d) { return key.path == d.path; });
      if (doc == keyDocs().end()) {
        undocumented += " " + key.path;
        continue;
      }
      key.unit = doc->unit;
      key.description = doc->description;
      key.defaultText = doc->defaultText;
    }
    for (const KeyDoc& doc : keyDocs())
      if (std::none_of(read.begin(), read.end(), [&](const SceneKey& k) { return k.path == doc.path; }))
        unread += std::string(" ") + doc.path;
    if (!undocumented.empty() || !unread.empty())
      throw std::logic_error("the scene key table (SceneSchema.cpp) is out of step with the parser:" +
                             (undocumented.empty() ? "" : " not documented:" + undocumented) +
                             (unread.empty() ? "" : "; documented but not read:" + unread));
    return read;
  }();
  return keys;
}

namespace {

/// The JSON Schema of one key, without its children.
json keySchema(const SceneKey& key) {
  json schema;
  const auto bounds = [&](json& target) {
    if (key.minimum) target[key.exclusiveMinimum ? "exclusiveMinimum" : "minimum"] = *key.minimum;
    if (key.maximum) target["maximum"] = *key.maximum;
  };
  if (key.kind == "object") {
    schema = {{"type", "object"}, {"properties", json::object()}, {"additionalProperties", false}};
  } else if (key.kind == "array") {
    schema = {{"type", "array"}, {"items", {{"type", "object"}, {"properties", json::object()},
                                            {"additionalProperties", false}}}};
  } else if (key.kind == "number" || key.kind == "integer") {
    schema = {{"type", key.kind}};
    bounds(schema);
  } else if (key.kind == "boolean" || key.kind == "string") {
    schema = {{"type", key.kind}};
  } else if (key.kind == "enum") {
    schema = {{"enum", key.choices}};
  } else if (key.kind == "vector") {
    json item = {{"type", "number"}};
    bounds(item);
    schema = {{"type", "array"}, {"items", item}, {"minItems", key.size ? key.size : 2},
              {"maxItems", key.size ? key.size : 3}};
  }
  std::string description = key.description;
  if (!key.unit.empty()) description += " [" + key.unit + "]";
  schema["description"] = description;
  if (!key.fallback.is_null() && key.defaultText.empty()) schema["default"] = key.fallback;
  return schema;
}

/// The object schema (properties, required) that the children of `path` go in.
json& parentOf(json& root, const std::string& path, std::string& name) {
  json* node = &root;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    std::string part = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (dot == std::string::npos) {
      name = part;
      return *node;
    }
    const bool item = part.size() > 2 && part.compare(part.size() - 2, 2, "[]") == 0;
    if (item) part.resize(part.size() - 2);
    json& child = (*node)["properties"][part];
    // Optional blocks accept null (absent): their object schema sits in anyOf[0].
    json& object = child.contains("anyOf") ? child["anyOf"][0] : child;
    node = item ? &object["items"] : &object;
    start = dot + 1;
  }
}

std::string typeText(const SceneKey& key) {
  if (key.kind == "object") return "object";
  if (key.kind == "array") return "array of objects";
  if (key.kind == "boolean") return "true or false";
  if (key.kind == "enum") {
    std::string text;
    for (std::size_t i = 0; i < key.choices.size(); ++i) text += (i ? ", " : "") + ("`" + key.choices[i] + "`");
    return "one of " + text;
  }
  if (key.kind == "vector") return key.size ? "[" + std::to_string(key.size) + " numbers]" : "[2 or 3 numbers]";
  return key.kind;
}

std::string limitsText(const SceneKey& key) {
  std::string text;
  if (key.minimum) text += (key.exclusiveMinimum ? "> " : ">= ") + formatNumber(*key.minimum);
  if (key.maximum) text += (text.empty() ? "<= " : ", <= ") + formatNumber(*key.maximum);
  return text;
}

std::string defaultText(const SceneKey& key) {
  if (!key.defaultText.empty()) return key.defaultText;
  if (key.required) return "required";
  if (key.fallback.is_null()) return "";
  if (key.fallback.is_number()) return formatNumber(key.fallback.get<double>());
  if (key.fallback.is_array()) {
    std::string text = "[";
    for (std::size_t i = 0; i < key.fallback.size(); ++i)
      text += (i ? ", " : "") + (key.fallback[i].is_number() ? formatNumber(key.fallback[i].get<double>())
                                                              : key.fallback[i].dump());
    return "`" + text + "]`";
  }
  return "`" + key.fallback.dump() + "`";
}

} // namespace

json sceneJsonSchema() {
  json root = {{"$schema", "https://json-schema.org/draft/2020-12/schema"},
               {"title", "Cascade scene"},
               {"description", "A Cascade scene file (docs/scenes.md): JSON, SI units, z up."},
               {"type", "object"},
               {"properties", json::object()},
               {"additionalProperties", false}};
  for (const SceneKey& key : sceneKeys()) {
    std::string name;
    json& parent = parentOf(root, key.path, name);
    json schema = keySchema(key);
    if (key.path == "presets")
      schema = {{"type", "object"},
                {"additionalProperties", {{"type", "object"}}},
                {"description", key.description}};
    if (key.required) {
      parent["required"].push_back(name);
    } else {
      // null reads as absent (OUT/scene.json writes absent optional keys as null).
      json outer = {{"description", schema.value("description", "")}};
      if (schema.contains("default")) outer["default"] = schema["default"];
      schema.erase("description");
      schema.erase("default");
      outer["anyOf"] = json::array({schema, {{"type", "null"}}});
      schema = outer;
    }
    parent["properties"][name] = schema;
  }
  return root;
}

std::string sceneKeysMarkdown() {
  std::ostringstream out;
  out << "# Scene files\n\n"
      << "<!-- Generated by `cascade schema --markdown` from the parser's own reading of the keys\n"
      << "     (libsph/scene/SceneSchema.cpp); edit the table there, not this file. -->\n\n"
      << "A scene is one JSON file, SI units (metres, seconds, kilograms), z up. The\n"
      << "shipped scenes in `scenes/` are examples; `cascade bake` writes `OUT/scene.json`\n"
      << "with every default filled in. This page lists every key: its type, unit,\n"
      << "default and limits. `cascade schema` prints the same as a JSON Schema\n"
      << "(draft 2020-12): save it (`cascade schema > cascade-scene.schema.json`) and\n"
      << "point an editor at it to check scenes as you type.\n\n"
      << "Rules that hold everywhere:\n\n"
      << "- An unknown key is an error (exit 2) that names it and the nearest known key.\n"
      << "- `null` reads as absent, so the default applies.\n"
      << "- Numbers must be finite; a scalar beyond 1e9, a vector component beyond 1e6\n"
      << "  or gravity beyond 1e3 m/s^2 is refused as an absurd magnitude.\n"
      << "- `\"size\"` picks one of the scene's `\"presets\"`: dotted paths and values,\n"
      << "  applied like `--set` where the file does not set the key itself. A file\n"
      << "  with presets and no size takes `production`. `--set size=seed` chooses\n"
      << "  another.\n"
      << "- `--set PATH=VALUE` (bake and run) replaces any value after the defaults\n"
      << "  are filled in: `--set fluid.spacing=0.01`,\n"
      << "  `--set boundaries.obstacles[0].dynamic.density=800`.\n"
      << "- Mesh paths are relative to the scene file.\n\n"
      << "In the paths below, `[]` stands for each item of an array.\n";
  std::string section = "#";
  for (const SceneKey& key : sceneKeys()) {
    // A block with keys of its own gets a section; plain top-level keys share one.
    const std::string top = key.path.substr(0, key.path.find_first_of(".["));
    const bool parent = std::any_of(sceneKeys().begin(), sceneKeys().end(), [&](const SceneKey& k) {
      return k.path.size() > top.size() && k.path.compare(0, top.size(), top) == 0 &&
             (k.path[top.size()] == '.' || k.path[top.size()] == '[');
    });
    const std::string heading = parent ? top : "";
    if (heading != section) {
      section = heading;
      out << "\n## " << (heading.empty() ? "Top level" : "`" + heading + "`") << "\n\n"
          << "| key | type | unit | default | limits | meaning |\n| --- | --- | --- | --- | --- | --- |\n";
    }
    out << "| `" << key.path << "` | " << typeText(key) << " | " << key.unit << " | " << defaultText(key) << " | "
        << limitsText(key) << " | " << key.description << " |\n";
  }
  return out.str();
}

} // namespace cascade::scene
