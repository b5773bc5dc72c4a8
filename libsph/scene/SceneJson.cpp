#include "libsph/scene/SceneJson.h"

#include "libsph/Errors.h"
#include "libsph/NeighborSearch.h"
#include "libsph/bodies/DeformingMesh.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/SceneSchema.h"
#include "libsph/solver/SolverSettings.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>
#include <sstream>

namespace cascade::scene {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string>& solverTypes() {
  // Add a solver here when libsph/solver gains a time-step strategy.
  static const std::vector<std::string> types{"wcsph", "dfsph"};
  return types;
}

const std::vector<std::string>& neighborSearchNames() {
  static const std::vector<std::string> names = neighborSearchMethods();
  return names;
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + cost});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string nearestWord(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t bestDistance = std::size_t(-1);
  for (const std::string& candidate : candidates) {
    const std::size_t d = editDistance(word, candidate);
    if (d < bestDistance) bestDistance = d, best = candidate;
  }
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 2);
  return bestDistance <= limit ? best : std::string();
}

namespace {

/// The largest magnitude a scene number may have (beyond: a typo or a unit mistake,
/// never a shot): scalars, vector components (m, m/s, colours) and gravity.
constexpr double kLargestScalar = 1e9, kLargestComponent = 1e6, kLargestGravity = 1e3;

std::string shortDump(const json& value) {
  std::string text = value.dump(-1, ' ', false, json::error_handler_t::replace);
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

std::string joinWords(const std::vector<std::string>& words) {
  std::string text;
  for (std::size_t i = 0; i < words.size(); ++i) text += (i ? ", " : "") + words[i];
  return text;
}

std::string formatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

/// While set (keysReadFrom), every key the parser reads is noted here with its kind,
/// default and limits: the scene format's reference (SceneSchema.h) is made of these.
thread_local std::vector<SceneKey>* tNotes = nullptr;

/// "probes[3].at" -> "probes[].at".
std::string patternOf(const std::string& path) {
  std::string pattern;
  for (std::size_t i = 0; i < path.size(); ++i) {
    pattern += path[i];
    if (path[i] != '[') continue;
    while (i + 1 < path.size() && path[i + 1] != ']') ++i;
  }
  return pattern;
}

/// Adds `key` to the notes, or merges it into the note of the same pattern: a key read
/// as "any" (found, not yet typed) takes the typed reading; one read in several places
/// (a probe's "at") is required only if every reading requires it.
void noteKey(SceneKey key) {
  if (!tNotes) return;
  key.path = patternOf(key.path);
  const auto same = std::find_if(tNotes->begin(), tNotes->end(), [&](const SceneKey& k) { return k.path == key.path; });
  if (same == tNotes->end()) {
    tNotes->push_back(std::move(key));
    return;
  }
  SceneKey& note = *same;
  if (key.kind == "any" || (note.kind == "enum" && key.kind == "string")) return;
  if (note.kind == "any" || (note.kind == "string" && key.kind == "enum")) {
    note = std::move(key);
    return;
  }
  if (note.kind != key.kind)
    throw std::logic_error("scene key " + key.path + " read as " + note.kind + " and as " + key.kind);
  note.required = note.required && key.required;
  if (note.size != key.size) note.size = 0;
  if (!note.minimum) note.minimum = key.minimum, note.exclusiveMinimum = key.exclusiveMinimum;
  if (!note.maximum) note.maximum = key.maximum;
  if (note.fallback.is_null()) note.fallback = key.fallback;
  if (note.choices.empty()) note.choices = key.choices;
}

/// Shared parse state: the file label for error messages and the scene's folder.
struct Context {
  std::string file;
  fs::path baseDir;
  /// OUT/scene.json: the stages after the bake never read the obstacles' mesh files
  /// (they read OUT/geometry), so a bake folder moved without them still parses.
  bool assetsOptional = false;

  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    throw InputError(file + ": " + path + ": " + message);
  }
};

enum class Range { Any, Positive, NonNegative };

/// The note of a key read with `range` (for a vector: of each of its numbers).
SceneKey keyNote(const std::string& path, const std::string& kind, json fallback, Range range, bool required = false) {
  SceneKey key;
  key.path = path;
  key.kind = kind;
  key.fallback = std::move(fallback);
  key.required = required;
  if (range != Range::Any) key.minimum = 0, key.exclusiveMinimum = range == Range::Positive;
  return key;
}

/// Reads one JSON object, remembering which keys were asked for, so that
/// finish() can reject the rest with a suggestion.
class ObjectReader {
public:
  ObjectReader(const Context& context, const json& value, std::string path)
      : mContext(context), mValue(value), mPath(std::move(path)) {
    if (!mValue.is_object()) fail(mPath, "must be an object (got " + shortDump(mValue) + ")");
    if (!mPath.empty()) noteKey(keyNote(mPath, "object", nullptr, Range::Any));
  }

  /// Notes a key read by hand (for the scene format's reference; see noteKey).
  void note(const std::string& key, const std::string& kind, json fallback, Range range = Range::Any,
            bool required = false, int size = 0) const {
    SceneKey k = keyNote(pathOf(key), kind, std::move(fallback), range, required);
    k.size = size;
    noteKey(std::move(k));
  }

  std::string pathOf(const std::string& key) const { return mPath.empty() ? key : mPath + "." + key; }
  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    mContext.fail(path.empty() ? "(top level)" : path, message);
  }
  const Context& context() const { return mContext; }

  /// The value at key, or nullptr if absent or null.
  const json* find(const std::string& key) {
    mKnown.push_back(key);
    note(key, "any", nullptr);
    const auto it = mValue.find(key);
    if (it == mValue.end() || it->is_null()) return nullptr;
    return &*it;
  }

  const json& require(const std::string& key) {
    const json* value = find(key);
    if (!value) fail(pathOf(key), "missing required key");
    return *value;
  }

  double number(const std::string& key, double fallback, Range range = Range::Any) {
    note(key, "number", fallback, range);
    const json* value = find(key);
    if (!value) return fallback;
    return checkNumber(*value, pathOf(key), range);
  }

  double requiredNumber(const std::string& key, Range range = Range::Any) {
    note(key, "number", nullptr, range, true);
    return checkNumber(require(key), pathOf(key), range);
  }

  double checkNumber(const json& value, const std::string& path, Range range,
                     double largest = kLargestScalar) const {
    if (!value.is_number()) fail(path, "must be a number (got " + shortDump(value) + ")");
    const double number = value.get<double>();
    if (!std::isfinite(number)) fail(path, "must be finite (got " + shortDump(value) + ")");
    if (std::abs(number) > largest)
      fail(path, "absurd magnitude (got " + formatNumber(number) + "; at most " + formatNumber(largest) + ")");
    if (range == Range::Positive && !(number > 0))
      fail(path, "must be > 0 (got " + formatNumber(number) + ")");
    if (range == Range::NonNegative && !(number >= 0))
      fail(path, "must be >= 0 (got " + formatNumber(number) + ")");
    return number;
  }

  double numberIn(const std::string& key, double fallback, double low, double high) {
    SceneKey k = keyNote(pathOf(key), "number", fallback, Range::Any);
    k.minimum = low, k.maximum = high;
    noteKey(std::move(k));
    const double value = number(key, fallback);
    if (value < low || value > high)
      fail(pathOf(key), "must be in [" + formatNumber(low) + ", " + formatNumber(high) + "] (got " +
                            formatNumber(value) + ")");
    return value;
  }

  std::int64_t integer(const std::string& key, std::int64_t fallback, std::int64_t low) {
    SceneKey k = keyNote(pathOf(key), "integer", fallback, Range::Any);
    k.minimum = double(low);
    noteKey(std::move(k));
    const json* value = find(key);
    if (!value) return fallback;
    if (!value->is_number_integer() && !(value->is_number() && std::floor(value->get<double>()) ==
                                                                   value->get<double>()))
      fail(pathOf(key), "must be an integer (got " + shortDump(*value) + ")");
    const std::int64_t result = value->get<std::int64_t>();
    if (result < low)
      fail(pathOf(key), "must be >= " + std::to_string(low) + " (got " + std::to_string(result) + ")");
    return result;
  }

  bool boolean(const std::string& key, bool fallback) {
    note(key, "boolean", fallback);
    const json* value = find(key);
    if (!value) return fallback;
    if (!value->is_boolean()) fail(pathOf(key), "must be true or false (got " + shortDump(*value) + ")");
    return value->get<bool>();
  }

  std::string string(const std::string& key, const std::string& fallback) {
    note(key, "string", fallback);
    const json* value = find(key);
    if (!value) return fallback;
    if (!value->is_string()) fail(pathOf(key), "must be a string (got " + shortDump(*value) + ")");
    return value->get<std::string>();
  }

  std::string requiredString(const std::string& key) {
    note(key, "string", nullptr, Range::Any, true);
    const json& value = require(key);
    if (!value.is_string()) fail(pathOf(key), "must be a string (got " + shortDump(value) + ")");
    const std::string text = value.get<std::string>();
    if (text.empty()) fail(pathOf(key), "must not be empty");
    return text;
  }

  std::string choice(const std::string& key, const std::string& fallback,
                     const std::vector<std::string>& allowed) {
    const std::string value = string(key, fallback);
    SceneKey k = keyNote(pathOf(key), "enum", fallback.empty() ? json(nullptr) : json(fallback), Range::Any,
                         fallback.empty());
    k.choices = allowed;
    noteKey(std::move(k));
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
      const std::string near = nearestWord(value, allowed);
      fail(pathOf(key), "must be one of " + joinWords(allowed) + " (got \"" + value + "\")" +
                            (near.empty() ? "" : " (did you mean '" + near + "'?)"));
    }
    return value;
  }

  template <std::size_t N>
  std::array<double, N> vector(const std::string& key, const std::array<double, N>& fallback,
                               Range range = Range::Any) {
    note(key, "vector", fallback, range, false, int(N));
    const json* value = find(key);
    if (!value) return fallback;
    return checkVector<N>(*value, pathOf(key), range);
  }

  template <std::size_t N>
  std::array<double, N> requiredVector(const std::string& key, Range range = Range::Any) {
    note(key, "vector", nullptr, range, true, int(N));
    return checkVector<N>(require(key), pathOf(key), range);
  }

  template <std::size_t N>
  std::array<double, N> checkVector(const json& value, const std::string& path, Range range) const {
    if (!value.is_array() || value.size() != N)
      fail(path, "must be an array of " + std::to_string(N) + " numbers (got " + shortDump(value) + ")");
    std::array<double, N> result{};
    for (std::size_t i = 0; i < N; ++i)
      result[i] = checkNumber(value[i], path + "[" + std::to_string(i) + "]", range, kLargestComponent);
    return result;
  }

  /// Calls read(item, path) for every element of the array at key (absent: none).
  void array(const std::string& key, const std::function<void(const json&, const std::string&)>& read) {
    note(key, "array", nullptr);
    const json* value = find(key);
    if (!value) return;
    if (!value->is_array()) fail(pathOf(key), "must be an array (got " + shortDump(*value) + ")");
    for (std::size_t i = 0; i < value->size(); ++i)
      read((*value)[i], pathOf(key) + "[" + std::to_string(i) + "]");
  }

  /// Rejects keys that were never asked for, suggesting the nearest known one.
  /// Fails on the first key not in `known`, naming the nearest (before reading: a
  /// misspelt required block is then named, not reported missing).
  void expectOnly(const std::vector<std::string>& known) const {
    for (auto it = mValue.begin(); it != mValue.end(); ++it) {
      if (std::find(known.begin(), known.end(), it.key()) != known.end()) continue;
      const std::string near = nearestWord(it.key(), known);
      fail(pathOf(it.key()), near.empty() ? "unknown key (known keys: " + joinWords(known) + ")"
                                          : "unknown key (did you mean '" + near + "'?)");
    }
  }

  void finish() const { expectOnly(mKnown); }

private:
  const Context& mContext;
  const json& mValue;
  std::string mPath;
  std::vector<std::string> mKnown;
};

double norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

Vec3 nonZeroVector(ObjectReader& reader, const std::string& key, const Vec3& fallback) {
  const Vec3 v = reader.vector<3>(key, fallback);
  if (!(norm(v) > 0)) reader.fail(reader.pathOf(key), "must not be the zero vector");
  return v;
}

Box readBox(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Box box;
  box.min = reader.requiredVector<3>("min");
  box.max = reader.requiredVector<3>("max");
  for (int k = 0; k < 3; ++k)
    if (!(box.max[k] > box.min[k]))
      reader.fail(reader.pathOf("max"), "must exceed min in every axis (axis " + std::to_string(k) +
                                            ": " + formatNumber(box.min[k]) + " >= " +
                                            formatNumber(box.max[k]) + ")");
  reader.finish();
  return box;
}

std::optional<Box> optionalBox(ObjectReader& parent, const std::string& key) {
  const json* value = parent.find(key);
  if (!value) return std::nullopt;
  return readBox(parent.context(), *value, parent.pathOf(key));
}

FluidBlock readBlock(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  FluidBlock block;
  block.box.min = reader.requiredVector<3>("min");
  block.box.max = reader.requiredVector<3>("max");
  for (int k = 0; k < 3; ++k)
    if (!(block.box.max[k] > block.box.min[k]))
      reader.fail(reader.pathOf("max"), "must exceed min in every axis");
  block.velocity = reader.vector<3>("velocity", block.velocity);
  reader.finish();
  return block;
}

Emitter readEmitter(const Context& context, const json& value, const std::string& path, std::size_t index) {
  ObjectReader reader(context, value, path);
  Emitter emitter;
  emitter.name = reader.string("name", "emitter" + std::to_string(index + 1));
  emitter.shape = reader.choice("shape", emitter.shape, {"disk", "rectangle"});
  emitter.center = reader.requiredVector<3>("center");
  emitter.normal = nonZeroVector(reader, "normal", emitter.normal);
  emitter.up = nonZeroVector(reader, "up", emitter.up);
  emitter.radius = reader.number("radius", emitter.radius, Range::Positive);
  emitter.size = reader.vector<2>("size", emitter.size, Range::Positive);
  emitter.speed = reader.number("speed", emitter.speed, Range::Positive);
  emitter.rate = reader.number("rate", emitter.rate, Range::NonNegative);
  emitter.start = reader.number("start", emitter.start, Range::NonNegative);
  emitter.end = reader.number("end", emitter.end, Range::NonNegative);
  if (!(emitter.end > emitter.start))
    reader.fail(reader.pathOf("end"), "must be > start (" + formatNumber(emitter.start) + ")");
  emitter.maxCount = reader.integer("max_count", emitter.maxCount, 0);
  if (emitter.shape == "rectangle") {
    // The height direction must not be parallel to the normal.
    const Vec3& n = emitter.normal;
    const Vec3& u = emitter.up;
    const Vec3 cross{n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
    if (!(norm(cross) > 1e-6 * norm(n) * norm(u)))
      reader.fail(reader.pathOf("up"), "must not be parallel to normal");
  }
  reader.finish();
  return emitter;
}

std::string resolveMesh(const ObjectReader& reader, const std::string& key, const std::string& given) {
  fs::path path(given);
  if (path.is_relative()) path = reader.context().baseDir / path;
  path = path.lexically_normal();
  std::error_code error;
  if (!reader.context().assetsOptional && !fs::is_regular_file(path, error))
    reader.fail(reader.pathOf(key), "mesh file not found: " + path.string());
  return fs::absolute(path, error).lexically_normal().string();
}

Keyframe readKeyframe(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Keyframe key;
  key.t = reader.requiredNumber("t");
  key.translate = reader.vector<3>("translate", key.translate);
  key.rotate = reader.vector<3>("rotate", key.rotate);
  reader.finish();
  return key;
}

Piston readPiston(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Piston piston;
  piston.axis = nonZeroVector(reader, "axis", piston.axis);  // kept as given; the consumer normalises
  piston.stroke = reader.number("stroke", piston.stroke, Range::NonNegative);
  piston.period = reader.number("period", piston.period, Range::Positive);
  piston.ramp = reader.number("ramp", piston.ramp, Range::NonNegative);
  reader.finish();
  return piston;
}

/// "motion": {"keyframes": [...]} or {"piston": {...}}, exactly one.
Motion readMotion(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Motion motion;
  const json* keyframes = reader.find("keyframes");
  const json* piston = reader.find("piston");
  if (keyframes && piston) reader.fail(path, "give either \"keyframes\" or \"piston\", not both");
  if (!keyframes && !piston) {
    reader.finish();  // a misspelt key: suggest the right one
    reader.fail(path, "needs \"keyframes\" or \"piston\"");
  }
  if (keyframes) {
    if (keyframes->is_array() && keyframes->empty())
      reader.fail(reader.pathOf("keyframes"), "must not be empty");
    reader.array("keyframes", [&](const json& item, const std::string& itemPath) {
      const Keyframe key = readKeyframe(context, item, itemPath);
      if (!motion.keyframes.empty() && !(key.t > motion.keyframes.back().t))
        context.fail(itemPath + ".t", "keyframes must be in increasing time order (" + formatNumber(key.t) +
                                          " after " + formatNumber(motion.keyframes.back().t) + ")");
      motion.keyframes.push_back(key);
    });
  } else {
    motion.piston = readPiston(context, *piston, reader.pathOf("piston"));
  }
  reader.finish();
  return motion;
}

/// "dynamic": {"density": RHO} or {"mass": M} (one of the two), "friction", "restitution".
Dynamic readDynamic(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Dynamic dynamic;
  const json* density = reader.find("density");
  const json* mass = reader.find("mass");
  if (density && mass) reader.fail(path, "give either \"density\" or \"mass\", not both");
  reader.note("density", "number", nullptr, Range::Positive);
  reader.note("mass", "number", nullptr, Range::Positive);
  if (density) dynamic.density = reader.checkNumber(*density, reader.pathOf("density"), Range::Positive);
  if (mass) dynamic.mass = reader.checkNumber(*mass, reader.pathOf("mass"), Range::Positive);
  dynamic.friction = reader.number("friction", dynamic.friction, Range::NonNegative);
  dynamic.restitution = reader.numberIn("restitution", dynamic.restitution, 0, 1);
  reader.finish();  // before "needs": a misspelt key gets its suggestion
  if (!density && !mass) reader.fail(path, "needs \"density\" or \"mass\"");
  return dynamic;
}

Obstacle readObstacle(const Context& context, const json& value, const std::string& path, std::size_t index) {
  ObjectReader reader(context, value, path);
  Obstacle obstacle;
  obstacle.name = reader.string("name", "obstacle" + std::to_string(index + 1));
  const std::string mesh = reader.requiredString("mesh");
  reader.string("mesh_hash", "");  // written into OUT/scene.json for the reader; the bake hashes the bytes itself
  obstacle.mesh = mesh;
  if (obstacle.isSequence()) {
    // A deforming sequence: its frames are checked once the output's frame count is known.
    fs::path pattern(mesh);
    if (pattern.is_relative()) pattern = context.baseDir / pattern;
    std::error_code error;
    obstacle.mesh = fs::absolute(pattern.lexically_normal(), error).lexically_normal().string();
  } else {
    obstacle.mesh = resolveMesh(reader, "mesh", mesh);
  }
  obstacle.translate = reader.vector<3>("translate", obstacle.translate);
  obstacle.rotate = reader.vector<3>("rotate", obstacle.rotate);
  obstacle.scale = reader.number("scale", obstacle.scale, Range::Positive);
  obstacle.triangles = reader.integer("triangles", obstacle.triangles, 0);
  const json* motion = reader.find("motion");
  const json* dynamic = reader.find("dynamic");
  if (motion && dynamic)
    reader.fail(reader.pathOf("dynamic"),
                "cannot be combined with \"motion\" (an obstacle moves as prescribed or is a rigid body, not both)");
  if (motion) obstacle.motion = readMotion(context, *motion, reader.pathOf("motion"));
  if (dynamic) obstacle.dynamic = readDynamic(context, *dynamic, reader.pathOf("dynamic"));
  reader.finish();
  if (obstacle.isSequence()) {
    if (motion || dynamic)
      reader.fail(reader.pathOf(motion ? "motion" : "dynamic"),
                  "a deforming mesh sequence moves as its frames say: it takes no \"motion\" or \"dynamic\"");
    if (obstacle.triangles > 0)
      reader.fail(reader.pathOf("triangles"),
                  "a deforming mesh sequence is not simplified (every frame must keep the same triangles)");
  }
  return obstacle;
}

Slope readSlope(const Context& context, const json& value, const std::string& path, std::size_t index) {
  ObjectReader reader(context, value, path);
  Slope slope;
  slope.name = reader.string("name", "slope" + std::to_string(index + 1));
  slope.center = reader.requiredVector<3>("center");
  slope.size = reader.requiredVector<3>("size", Range::Positive);
  slope.axis = nonZeroVector(reader, "axis", slope.axis);
  slope.angle = reader.numberIn("angle", slope.angle, -90, 90);
  reader.finish();
  return slope;
}

Plane readPlane(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Plane plane;
  plane.point = reader.requiredVector<3>("point");
  plane.normal = nonZeroVector(reader, "normal", plane.normal);
  reader.finish();
  return plane;
}

Light readLight(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Light light;
  light.type = reader.choice("type", light.type, {"directional", "point"});
  light.direction = nonZeroVector(reader, "direction", light.direction);
  light.position = reader.vector<3>("position", light.position);
  light.color = reader.vector<3>("color", light.color, Range::NonNegative);
  light.intensity = reader.number("intensity", light.intensity, Range::NonNegative);
  reader.finish();
  return light;
}

Probe readProbe(const Context& context, const json& value, const std::string& path) {
  ObjectReader reader(context, value, path);
  Probe probe;
  probe.name = reader.requiredString("name");
  for (char c : probe.name)
    if (c == ',' || c == '\n' || c == '"') reader.fail(reader.pathOf("name"), "must not contain , \" or newlines");
  probe.type = reader.choice("type", "", {"height", "pressure", "force", "front", "body", "velocity"});
  if (probe.type == "height") {
    reader.note("at", "vector", nullptr, Range::Any, true, 2);
    const json* at = reader.find("at");
    if (!at) reader.fail(reader.pathOf("at"), "missing required key");
    if (at->is_array() && at->size() == 2) {
      const auto xy = reader.checkVector<2>(*at, reader.pathOf("at"), Range::Any);
      probe.at = {xy[0], xy[1], 0};
    } else {
      probe.at = reader.checkVector<3>(*at, reader.pathOf("at"), Range::Any);
    }
  } else if (probe.type == "pressure" || probe.type == "velocity") {
    probe.at = reader.requiredVector<3>("at");
    if (probe.type == "pressure") {
      probe.radius = reader.number("radius", probe.radius, Range::NonNegative);
      if (reader.find("normal")) probe.normal = nonZeroVector(reader, "normal", probe.normal);
    }
  } else {
    probe.at = reader.vector<3>("at", probe.at);
  }
  if (probe.type == "force" || probe.type == "body") probe.obstacle = reader.requiredString("obstacle");
  else probe.obstacle = reader.string("obstacle", "");
  probe.direction = nonZeroVector(reader, "direction", probe.direction);
  reader.finish();
  return probe;
}

json vec(const Vec3& v) { return json::array({v[0], v[1], v[2]}); }
json box(const Box& b) { return json{{"min", vec(b.min)}, {"max", vec(b.max)}}; }

/// The unused alternative of each pair is written as null (read as absent), so
/// that `--set` can reach it, e.g. --set ...dynamic.density=null --set ...dynamic.mass=5.
json motionJson(const Motion& m) {
  json keyframes = nullptr;
  if (!m.piston) {
    keyframes = json::array();
    for (const Keyframe& k : m.keyframes)
      keyframes.push_back({{"t", k.t}, {"translate", vec(k.translate)}, {"rotate", vec(k.rotate)}});
  }
  json piston = nullptr;
  if (m.piston)
    piston = {{"axis", vec(m.piston->axis)},
              {"stroke", m.piston->stroke},
              {"period", m.piston->period},
              {"ramp", m.piston->ramp}};
  return {{"keyframes", keyframes}, {"piston", piston}};
}

json dynamicJson(const Dynamic& d) {
  return {{"density", d.density > 0 ? json(d.density) : json(nullptr)},
          {"mass", d.density > 0 ? json(nullptr) : json(d.mass)},
          {"friction", d.friction},
          {"restitution", d.restitution}};
}

} // namespace

int Output::frameCount() const {
  return std::max(1, int(std::floor(endTime * fps + 1e-9)));
}

static SurfaceSettings readSurfaceSettings(const Context& context, const json& value) {
  ObjectReader surface(context, value, "surface");
  SurfaceSettings settings;
  settings.method = surface.choice("method", settings.method, {"union", "smooth", "anisotropic"});
  settings.meshFormat = surface.choice("mesh_format", settings.meshFormat, {"obj", "ply"});
  settings.outputs = surface.choice("outputs", settings.outputs, {"both", "vdb", "mesh"});
  settings.velocity = surface.boolean("velocity", settings.velocity);
  settings.adaptivity = surface.numberIn("adaptivity", settings.adaptivity, 0, 1);
  settings.meshUp = surface.choice("mesh_up", settings.meshUp, {"y", "z"});
  settings.foamDensity = surface.boolean("foam_density", settings.foamDensity);
  surface.finish();
  return settings;
}

SurfaceSettings parseSurfaceSettings(const json& value, const std::string& fileLabel) {
  return readSurfaceSettings(Context{fileLabel, fs::path()}, value);
}

json surfaceSettingsToJson(const SurfaceSettings& settings) {
  return {{"method", settings.method},         {"mesh_format", settings.meshFormat}, {"outputs", settings.outputs},
          {"velocity", settings.velocity},     {"adaptivity", settings.adaptivity},  {"mesh_up", settings.meshUp},
          {"foam_density", settings.foamDensity}};
}

static WhitewaterSettings readWhitewaterSettings(const Context& context, const json& value) {
  ObjectReader reader(context, value, "whitewater");
  WhitewaterSettings w;
  // A [min, max] pair: both >= 0 and min < max (min == max would divide by zero in the clamp).
  const auto range = [&](const std::string& key, std::array<double, 2> fallback, bool allowEqual) {
    const std::array<double, 2> pair = reader.vector<2>(key, fallback, Range::NonNegative);
    if (pair[0] > pair[1] || (!allowEqual && pair[0] == pair[1]))
      reader.fail(reader.pathOf(key), std::string("min must be ") + (allowEqual ? "<=" : "<") + " max (got [" +
                                          formatNumber(pair[0]) + ", " + formatNumber(pair[1]) + "])");
    return pair;
  };
  w.limits = reader.choice("limits", w.limits, {"auto", "fixed"});
  w.trappedAir = range("trapped_air", w.trappedAir, false);
  w.waveCrest = range("wave_crest", w.waveCrest, false);
  w.kineticEnergy = range("kinetic_energy", w.kineticEnergy, false);
  w.trappedAirRate = reader.number("trapped_air_rate", w.trappedAirRate, Range::NonNegative);
  w.waveCrestRate = reader.number("wave_crest_rate", w.waveCrestRate, Range::NonNegative);
  w.rateScale = reader.number("rate_scale", w.rateScale, Range::NonNegative);
  w.ratesPer = reader.choice("rates_per", w.ratesPer, {"particle", "area", "volume"});
  w.referenceSpacing = reader.number("reference_spacing", w.referenceSpacing, Range::NonNegative);
  if (w.ratesPer == "particle" && w.referenceSpacing > 0)
    reader.fail(reader.pathOf("reference_spacing"),
                "has no effect with rates per particle (set rates_per to \"area\" or \"volume\")");
  if (w.ratesPer != "particle" && !(w.referenceSpacing > 0))
    reader.fail(reader.pathOf("rates_per"), "\"" + w.ratesPer + "\" needs reference_spacing, the spacing m the rates are for");
  w.lifetime = range("lifetime", w.lifetime, true);
  w.sprayNeighbors = int(reader.integer("spray_neighbors", w.sprayNeighbors, 0));
  w.bubbleNeighbors = int(reader.integer("bubble_neighbors", w.bubbleNeighbors, 0));
  if (w.bubbleNeighbors < w.sprayNeighbors)
    reader.fail(reader.pathOf("bubble_neighbors"), "must be >= spray_neighbors (got " +
                                                       std::to_string(w.bubbleNeighbors) + " < " +
                                                       std::to_string(w.sprayNeighbors) + ")");
  w.buoyancy = reader.number("buoyancy", w.buoyancy, Range::Any);
  w.bubbleDrag = reader.number("bubble_drag", w.bubbleDrag, Range::Positive);
  w.airDrag = reader.number("air_drag", w.airDrag, Range::NonNegative);
  w.substeps = int(reader.integer("substeps", w.substeps, 0));
  if (w.substeps > 1000) reader.fail(reader.pathOf("substeps"), "must be <= 1000 (got " + std::to_string(w.substeps) + ")");
  w.seed = reader.integer("seed", w.seed, 0);
  w.ply = reader.boolean("ply", w.ply);
  reader.finish();
  return w;
}

WhitewaterSettings parseWhitewaterSettings(const json& value, const std::string& fileLabel) {
  return readWhitewaterSettings(Context{fileLabel, fs::path()}, value);
}

json whitewaterSettingsToJson(const WhitewaterSettings& w) {
  json out{{"limits", w.limits},
          {"trapped_air", w.trappedAir},
          {"wave_crest", w.waveCrest},
          {"kinetic_energy", w.kineticEnergy},
          {"trapped_air_rate", w.trappedAirRate},
          {"wave_crest_rate", w.waveCrestRate},
          {"rate_scale", w.rateScale},
          {"lifetime", w.lifetime},
          {"spray_neighbors", w.sprayNeighbors},
          {"bubble_neighbors", w.bubbleNeighbors},
          {"buoyancy", w.buoyancy},
          {"bubble_drag", w.bubbleDrag},
          {"air_drag", w.airDrag},
          {"substeps", w.substeps},
          {"seed", w.seed},
          {"ply", w.ply}};
  // Only when set: the stage's input hash (made from this) stays that of the
  // settings before the key existed, so their frames are kept.
  if (w.ratesPer != "particle") {
    out["rates_per"] = w.ratesPer;
    out["reference_spacing"] = w.referenceSpacing;
  }
  return out;
}

namespace {
Scene parseSceneIn(const json& value, const Context& context) {
  ObjectReader top(context, value, "");
  top.expectOnly({"name", "description", "size", "gravity", "fluid", "solver", "boundaries", "output", "surface",
                  "whitewater", "camera", "lights", "probes"});
  Scene scene;
  scene.name = top.string("name", scene.name);
  if (scene.name.empty() || scene.name.find('/') != std::string::npos)
    top.fail("name", "must be a non-empty name without '/' (got \"" + scene.name + "\")");
  scene.description = top.string("description", scene.description);
  scene.size = top.string("size", scene.size);
  scene.gravity = top.vector<3>("gravity", scene.gravity);
  if (norm(scene.gravity) > kLargestGravity)
    top.fail("gravity", "absurd magnitude (|g| = " + formatNumber(norm(scene.gravity)) + " m/s^2; at most " +
                            formatNumber(kLargestGravity) + ")");

  if (const json* fluidJson = top.find("fluid")) {
    ObjectReader fluid(context, *fluidJson, "fluid");
    scene.fluid.spacing = fluid.number("spacing", scene.fluid.spacing, Range::Positive);
    scene.fluid.density = fluid.number("density", scene.fluid.density, Range::Positive);
    scene.fluid.viscosity = fluid.number("viscosity", scene.fluid.viscosity, Range::NonNegative);
    fluid.array("blocks", [&](const json& item, const std::string& path) {
      scene.fluid.blocks.push_back(readBlock(context, item, path));
    });
    fluid.array("emitters", [&](const json& item, const std::string& path) {
      scene.fluid.emitters.push_back(readEmitter(context, item, path, scene.fluid.emitters.size()));
    });
    fluid.finish();
  }
  if (scene.fluid.blocks.empty() && scene.fluid.emitters.empty())
    top.fail("fluid", "needs at least one block or emitter");

  if (const json* solverJson = top.find("solver")) {
    ObjectReader solver(context, *solverJson, "solver");
    Solver& s = scene.solver;
    s.type = solver.choice("type", s.type, solverTypes());
    s.eos = solver.choice("eos", s.eos, {"linear", "tait"});
    s.stiffness = solver.number("stiffness", s.stiffness, Range::NonNegative);
    s.taitExponent = solver.numberIn("tait_exponent", s.taitExponent, 1, 10);
    s.clampNegativePressure = solver.boolean("clamp_negative_pressure", s.clampNegativePressure);
    s.kernels = solver.choice("kernels", s.kernels, {"auto", "wendland_c2", "cubic_spline", "mueller2003"});
    s.pressureForce = solver.choice("pressure_force", s.pressureForce, {"hamiltonian", "symmetric", "mueller_half"});
    s.surfaceLayerPressure = solver.boolean("surface_layer_pressure", s.surfaceLayerPressure);
    s.density = solver.choice("density", s.density, {"summation", "continuity"});
    s.densityDiffusion = solver.numberIn("density_diffusion", s.densityDiffusion, 0, 1);
    s.velocityFilter = solver.numberIn("velocity_filter", s.velocityFilter, 0, 1);
    s.artificialViscosity = solver.numberIn("artificial_viscosity", s.artificialViscosity, 0, 2);
    s.artificialViscosityAllPairs = solver.boolean("artificial_viscosity_all_pairs", s.artificialViscosityAllPairs);
    s.expectedSpeed = solver.number("expected_speed", s.expectedSpeed, Range::NonNegative);
    s.instabilitySpeedFactor = solver.numberIn("instability_speed_factor", s.instabilitySpeedFactor, 1, 1e6);
    s.densityTolerance = solver.numberIn("density_tolerance", s.densityTolerance, 1e-7, 0.5);
    s.divergenceTolerance = solver.numberIn("divergence_tolerance", s.divergenceTolerance, 1e-7, 10);
    s.maxIterations = solver.integer("max_iterations", s.maxIterations, 1);
    s.preconditioner = solver.choice("preconditioner", s.preconditioner, {"two_level", "jacobi"});
    s.particleToleranceShare = solver.numberIn("particle_tolerance_share", s.particleToleranceShare, 0, 1e3);
    s.supportFactor =
        solver.numberIn("support_factor", s.supportFactor > 0 ? s.supportFactor : defaultSupportFactor(s.type), 1.0, 4.0);
    s.cfl = solver.numberIn("cfl", s.cfl, 1e-3, 1.0);
    s.dtMin = solver.number("dt_min", s.dtMin, Range::Positive);
    s.dtMax = solver.number("dt_max", s.dtMax, Range::Positive);
    if (s.dtMax < s.dtMin)
      solver.fail("solver.dt_max", "must be >= dt_min (" + formatNumber(s.dtMin) + ") (got " +
                                       formatNumber(s.dtMax) + ")");
    s.neighborSearch = solver.choice("neighbor_search", s.neighborSearch, neighborSearchNames());
    s.reorderInterval = solver.integer("reorder_interval", s.reorderInterval, 0);
    s.repulsionParticles = solver.boolean("repulsion_particles", s.repulsionParticles);
    s.mirrorParticles = solver.boolean("mirror_particles", s.mirrorParticles);
    s.mirrorHydrostatic = solver.boolean("mirror_hydrostatic", s.mirrorHydrostatic);
    s.repulsion = solver.number("repulsion", s.repulsion, Range::NonNegative);
    s.repulsionRadius = solver.number("repulsion_radius", s.repulsionRadius, Range::NonNegative);
    s.sampleGap = solver.numberIn("sample_gap", s.sampleGap, 0.05, 1.0);
    s.slip = solver.choice("slip", s.slip, {"free", "no", "laminar"});  // laminar: MirrorSlip::LaminarWallShear
    s.kappa = solver.numberIn("kappa", s.kappa, 0.5, 2.0);
    solver.finish();
  }
  // The solver's own support when the scene gives none (also without a solver block).
  if (!(scene.solver.supportFactor > 0)) scene.solver.supportFactor = defaultSupportFactor(scene.solver.type);

  if (const json* boundariesJson = top.find("boundaries")) {
    ObjectReader boundaries(context, *boundariesJson, "boundaries");
    Boundaries& b = scene.boundaries;
    b.tank = optionalBox(boundaries, "tank");
    boundaries.array("planes", [&](const json& item, const std::string& path) {
      b.planes.push_back(readPlane(context, item, path));
    });
    boundaries.array("slopes", [&](const json& item, const std::string& path) {
      b.slopes.push_back(readSlope(context, item, path, b.slopes.size()));
    });
    boundaries.array("obstacles", [&](const json& item, const std::string& path) {
      b.obstacles.push_back(readObstacle(context, item, path, b.obstacles.size()));
      for (std::size_t i = 0; i + 1 < b.obstacles.size(); ++i)
        if (b.obstacles[i].name == b.obstacles.back().name)
          context.fail(path + ".name", "duplicate obstacle name \"" + b.obstacles.back().name + "\"");
    });
    b.domain = optionalBox(boundaries, "domain");
    boundaries.array("kill", [&](const json& item, const std::string& path) {
      b.kill.push_back(readBox(context, item, path));
    });
    boundaries.finish();
  }

  if (const json* outputJson = top.find("output")) {
    ObjectReader output(context, *outputJson, "output");
    scene.output.fps = output.numberIn("fps", scene.output.fps, 1e-3, 10000);
    scene.output.endTime = output.number("end_time", scene.output.endTime, Range::Positive);
    scene.output.probeRate = output.numberIn("probe_rate", scene.output.probeRate, 1e-3, 1e6);
    if (scene.output.endTime * scene.output.fps > 100000)
      output.fail("output.end_time", "more than 100000 frames at this fps");
    output.finish();
  }

  // Deforming sequences: every frame the bake reaches (1 to the last) must be there.
  for (std::size_t k = 0; k < scene.boundaries.obstacles.size() && !context.assetsOptional; ++k) {
    const Obstacle& obstacle = scene.boundaries.obstacles[k];
    if (!obstacle.isSequence()) continue;
    const int frames = scene.output.frameCount();
    for (int f = 1; f <= frames; ++f) {
      const std::string file = sequenceFramePath(obstacle.mesh, f);
      std::error_code error;
      if (!fs::is_regular_file(file, error))
        context.fail("boundaries.obstacles[" + std::to_string(k) + "].mesh",
                     "frame " + std::to_string(f) + " of the mesh sequence is missing: " + file +
                         " (the bake runs to frame " + std::to_string(frames) + ")");
    }
  }

  if (const json* surfaceJson = top.find("surface")) scene.surface = readSurfaceSettings(context, *surfaceJson);
  if (const json* whitewaterJson = top.find("whitewater"))
    scene.whitewater = readWhitewaterSettings(context, *whitewaterJson);

  if (const json* cameraJson = top.find("camera")) {
    ObjectReader camera(context, *cameraJson, "camera");
    scene.camera.position = camera.vector<3>("position", scene.camera.position);
    scene.camera.target = camera.vector<3>("target", scene.camera.target);
    scene.camera.up = nonZeroVector(camera, "up", scene.camera.up);
    scene.camera.fov = camera.numberIn("fov", scene.camera.fov, 1, 170);
    const Vec3& p = scene.camera.position;
    const Vec3& t = scene.camera.target;
    if (norm(Vec3{p[0] - t[0], p[1] - t[1], p[2] - t[2]}) == 0)
      camera.fail("camera.target", "must differ from camera.position");
    camera.finish();
  }

  if (top.find("lights")) {
    top.array("lights", [&](const json& item, const std::string& path) {
      scene.lights.push_back(readLight(context, item, path));
    });
  } else {
    // Default: a key light from above and a dim fill.
    Light key;
    Light fill;
    fill.direction = {0.5, -0.6, -0.4};
    fill.intensity = 0.35;
    scene.lights = {key, fill};
  }

  top.array("probes", [&](const json& item, const std::string& path) {
    Probe probe = readProbe(context, item, path);
    for (const Probe& other : scene.probes)
      if (other.name == probe.name) context.fail(path + ".name", "duplicate probe name \"" + probe.name + "\"");
    if (probe.type == "force" || probe.type == "body") {
      // A body probe follows an obstacle that moves: one with "motion" or "dynamic".
      const bool body = probe.type == "body";
      const auto moves = [](const Obstacle& o) { return o.motion.has_value() || o.dynamic.has_value(); };
      const auto& obstacles = scene.boundaries.obstacles;
      const auto named = std::find_if(obstacles.begin(), obstacles.end(),
                                      [&](const Obstacle& o) { return o.name == probe.obstacle; });
      if (named == obstacles.end() || (body && !moves(*named))) {
        std::vector<std::string> names;
        for (const Obstacle& o : obstacles)
          if (!body || moves(o)) names.push_back(o.name);
        const std::string near = nearestWord(probe.obstacle, names);
        const std::string suggestion = near.empty() ? "" : " (did you mean '" + near + "'?)";
        if (named == obstacles.end())
          context.fail(path + ".obstacle", "no obstacle named \"" + probe.obstacle + "\"" + suggestion);
        context.fail(path + ".obstacle", "obstacle \"" + probe.obstacle +
                                             "\" stands still; a body probe needs one with \"motion\" or "
                                             "\"dynamic\"" + suggestion);
      }
    }
    if (probe.type == "pressure" && probe.radius > 0 && probe.normal == Vec3{0, 0, 0}) {
      // The sensor face lies on the tank wall nearest its centre (within two spacings).
      double nearest = 2 * scene.fluid.spacing;
      if (const auto& tank = scene.boundaries.tank) {
        for (int a = 0; a < 3; ++a)
          for (int side = 0; side < 2; ++side) {
            if (a == 2 && side == 1) continue;  // the open top
            const double distance = std::abs(probe.at[a] - (side ? tank->max[a] : tank->min[a]));
            if (distance <= nearest) {
              nearest = distance;
              probe.normal = {0, 0, 0};
              probe.normal[a] = side ? -1 : 1;
            }
          }
      }
      if (probe.normal == Vec3{0, 0, 0})
        context.fail(path + ".normal", "a pressure probe with a radius needs the sensor face's normal (its centre is "
                                       "not on a tank wall)");
    }
    scene.probes.push_back(std::move(probe));
  });

  top.finish();
  return scene;
}
} // namespace

Scene parseScene(const json& value, const std::string& fileLabel, const fs::path& baseDir) {
  return parseSceneIn(value, Context{fileLabel, baseDir});
}

std::vector<SceneKey> keysReadFrom(const json& value, const fs::path& baseDir) {
  std::vector<SceneKey> notes;
  struct Recording {
    explicit Recording(std::vector<SceneKey>* notes) { tNotes = notes; }
    ~Recording() { tNotes = nullptr; }
  } recording(&notes);
  Context context{"scene", baseDir};
  context.assetsOptional = true;
  parseSceneIn(value, context);
  return notes;
}

json sceneToJson(const Scene& scene) {
  json fluid;
  fluid["spacing"] = scene.fluid.spacing;
  fluid["density"] = scene.fluid.density;
  fluid["viscosity"] = scene.fluid.viscosity;
  fluid["blocks"] = json::array();
  for (const FluidBlock& block : scene.fluid.blocks)
    fluid["blocks"].push_back({{"min", vec(block.box.min)}, {"max", vec(block.box.max)},
                               {"velocity", vec(block.velocity)}});
  fluid["emitters"] = json::array();
  for (const Emitter& e : scene.fluid.emitters)
    fluid["emitters"].push_back({{"name", e.name},       {"shape", e.shape},
                                 {"center", vec(e.center)}, {"normal", vec(e.normal)},
                                 {"up", vec(e.up)},       {"radius", e.radius},
                                 {"size", {e.size[0], e.size[1]}}, {"speed", e.speed},
                                 {"rate", e.rate},        {"start", e.start},
                                 {"end", e.end},          {"max_count", e.maxCount}});

  const Solver& s = scene.solver;
  json solver{{"type", s.type},
              {"eos", s.eos},
              {"stiffness", s.stiffness},
              {"tait_exponent", s.taitExponent},
              {"clamp_negative_pressure", s.clampNegativePressure},
              {"kernels", s.kernels},
              {"pressure_force", s.pressureForce},
              {"surface_layer_pressure", s.surfaceLayerPressure},
              {"density", s.density},
              {"density_diffusion", s.densityDiffusion},
              {"velocity_filter", s.velocityFilter},
              {"artificial_viscosity", s.artificialViscosity},
              {"artificial_viscosity_all_pairs", s.artificialViscosityAllPairs},
              {"expected_speed", s.expectedSpeed},
              {"instability_speed_factor", s.instabilitySpeedFactor},
              {"density_tolerance", s.densityTolerance},
              {"divergence_tolerance", s.divergenceTolerance},
              {"max_iterations", s.maxIterations},
              {"preconditioner", s.preconditioner},
              {"particle_tolerance_share", s.particleToleranceShare},
              {"support_factor", s.supportFactor},
              {"cfl", s.cfl},
              {"dt_min", s.dtMin},
              {"dt_max", s.dtMax},
              {"neighbor_search", s.neighborSearch},
              {"reorder_interval", s.reorderInterval},
              {"repulsion_particles", s.repulsionParticles},
              {"mirror_particles", s.mirrorParticles},
              {"mirror_hydrostatic", s.mirrorHydrostatic},
              {"repulsion", s.repulsion},
              {"repulsion_radius", s.repulsionRadius},
              {"sample_gap", s.sampleGap},
              {"slip", s.slip},
              {"kappa", s.kappa}};

  const Boundaries& b = scene.boundaries;
  json boundaries;
  boundaries["tank"] = b.tank ? box(*b.tank) : json(nullptr);
  boundaries["planes"] = json::array();
  for (const Plane& p : b.planes) boundaries["planes"].push_back({{"point", vec(p.point)}, {"normal", vec(p.normal)}});
  boundaries["slopes"] = json::array();
  for (const Slope& sl : b.slopes)
    boundaries["slopes"].push_back({{"name", sl.name},
                                    {"center", vec(sl.center)},
                                    {"size", vec(sl.size)},
                                    {"axis", vec(sl.axis)},
                                    {"angle", sl.angle}});
  boundaries["obstacles"] = json::array();
  for (const Obstacle& o : b.obstacles)
    boundaries["obstacles"].push_back({{"name", o.name},
                                       {"mesh", o.mesh},
                                       {"translate", vec(o.translate)},
                                       {"rotate", vec(o.rotate)},
                                       {"scale", o.scale},
                                       {"triangles", o.triangles},
                                       {"motion", o.motion ? motionJson(*o.motion) : json(nullptr)},
                                       {"dynamic", o.dynamic ? dynamicJson(*o.dynamic) : json(nullptr)}});
  boundaries["domain"] = b.domain ? box(*b.domain) : json(nullptr);
  boundaries["kill"] = json::array();
  for (const Box& k : b.kill) boundaries["kill"].push_back(box(k));

  json lights = json::array();
  for (const Light& l : scene.lights)
    lights.push_back({{"type", l.type},
                      {"direction", vec(l.direction)},
                      {"position", vec(l.position)},
                      {"color", vec(l.color)},
                      {"intensity", l.intensity}});
  json probes = json::array();
  for (const Probe& p : scene.probes) {
    json probe{{"name", p.name}, {"type", p.type}, {"at", vec(p.at)}, {"direction", vec(p.direction)}};
    if (p.type == "force" || p.type == "body" || !p.obstacle.empty()) probe["obstacle"] = p.obstacle;
    if (p.type == "pressure" && p.radius > 0) {
      probe["radius"] = p.radius;
      probe["normal"] = vec(p.normal);
    }
    probes.push_back(probe);
  }

  json result;
  result["name"] = scene.name;
  result["description"] = scene.description;
  result["size"] = scene.size;
  result["gravity"] = vec(scene.gravity);
  result["fluid"] = fluid;
  result["solver"] = solver;
  result["boundaries"] = boundaries;
  result["output"] = {{"fps", scene.output.fps},
                      {"end_time", scene.output.endTime},
                      {"probe_rate", scene.output.probeRate}};
  result["surface"] = surfaceSettingsToJson(scene.surface);
  result["whitewater"] = scene.whitewater ? whitewaterSettingsToJson(*scene.whitewater) : json(nullptr);
  result["camera"] = {{"position", vec(scene.camera.position)},
                      {"target", vec(scene.camera.target)},
                      {"up", vec(scene.camera.up)},
                      {"fov", scene.camera.fov}};
  result["lights"] = lights;
  result["probes"] = probes;
  return result;
}

namespace {
std::vector<std::string> splitPath(const std::string& path, const std::string& label) {
  std::vector<std::string> parts;
  std::string current;
  for (char c : path) {
    if (c == '.' || c == '[' || c == ']') {
      if (!current.empty()) parts.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  if (!current.empty()) parts.push_back(current);
  if (parts.empty()) throw InputError(label + ": empty path");
  return parts;
}

bool parseIndex(const std::string& text, std::size_t& index) {
  if (text.empty() || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return false;
  index = std::stoul(text);
  return true;
}

/// True if `root` holds a value at the dotted path (a preset's key the scene file sets itself).
bool hasJsonPath(const json& root, const std::string& path) {
  const json* node = &root;
  for (const std::string& part : splitPath(path, path)) {
    std::size_t index = 0;
    if (node->is_array() && parseIndex(part, index) && index < node->size()) {
      node = &(*node)[index];
    } else if (node->is_object() && node->contains(part)) {
      node = &(*node)[part];
    } else {
      return false;
    }
  }
  return true;
}
} // namespace

void setJsonPath(json& root, const std::string& path, const json& value, const std::string& label,
                 bool mustExist) {
  const std::vector<std::string> parts = splitPath(path, label);
  json* node = &root;
  std::string walked;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const std::string& part = parts[k];
    const bool last = k + 1 == parts.size();
    const std::string here = walked.empty() ? part : walked + "." + part;
    if (node->is_array()) {
      std::size_t index = 0;
      if (!parseIndex(part, index))
        throw InputError(label + " " + path + ": " + walked + " is an array; expected an index (got '" + part + "')");
      if (index >= node->size())
        throw InputError(label + " " + path + ": " + walked + " has " + std::to_string(node->size()) +
                         " entries (index " + part + " out of range)");
      node = &(*node)[index];
    } else if (node->is_object() || (!mustExist && node->is_null())) {
      if (node->is_null()) *node = json::object();
      if (!node->contains(part)) {
        if (mustExist) {
          std::vector<std::string> keys;
          for (auto it = node->begin(); it != node->end(); ++it) keys.push_back(it.key());
          const std::string near = nearestWord(part, keys);
          throw InputError(label + " " + path + ": unknown key '" + here + "'" +
                           (near.empty() ? "" : " (did you mean '" + (walked.empty() ? near : walked + "." + near) + "'?)"));
        }
        (*node)[part] = last ? json(nullptr) : json::object();
      }
      node = &(*node)[part];
    } else {
      throw InputError(label + " " + path + ": " + (walked.empty() ? "(top level)" : walked) +
                       " is " + (node->is_null() ? "null; set the whole object instead" : "not an object"));
    }
    walked = here;
  }
  *node = value;
}

void setJsonPath(json& root, const std::string& path, const std::string& text, const std::string& label,
                 bool mustExist) {
  json value;
  try {
    value = json::parse(text);
  } catch (const json::parse_error&) {
    value = text;  // not JSON: a string, which must be UTF-8 as a file's strings are
    try {
      (void)value.dump();
    } catch (const json::type_error&) {
      throw InputError(label + " " + path + ": the value is not valid UTF-8");
    }
  } catch (const json::out_of_range&) {
    throw InputError(label + " " + path + "=" + text + ": the number overflows a double");
  }
  setJsonPath(root, path, value, label, mustExist);
}

namespace {
json parseJsonText(const std::string& text, const std::string& label) {
  try {
    return json::parse(text);
  } catch (const json::exception& bad) {
    // What parse throws: "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
    // or "[json.exception.out_of_range.406] number overflow parsing '1e999'"; the text after "] ".
    std::string message = bad.what();
    const auto at = message.find("] ");
    if (message.rfind("[json.exception.", 0) == 0 && at != std::string::npos) message = message.substr(at + 2);
    throw InputError(label + ": invalid JSON: " + message);
  }
}

json readJsonFile(const fs::path& file) {
  std::error_code error;
  if (!fs::is_regular_file(file, error)) throw InputError(file.string() + ": scene file not found");
  return parseJsonText(readTextFile(file), file.string());
}

std::pair<std::string, std::string> splitOverride(const std::string& text) {
  const auto equals = text.find('=');
  if (equals == std::string::npos || equals == 0)
    throw InputError("--set " + text + ": expected KEY=VALUE");
  return {text.substr(0, equals), text.substr(equals + 1)};
}
} // namespace

Scene loadScene(const fs::path& file, const std::vector<std::string>& overrides) {
  std::error_code error;
  if (!fs::is_regular_file(file, error)) throw InputError(file.string() + ": scene file not found");
  fs::path baseDir = file.parent_path();
  if (baseDir.empty()) baseDir = ".";
  return loadSceneText(readTextFile(file), file.string(), baseDir, overrides);
}

Scene loadSceneText(const std::string& text, const std::string& label, const fs::path& baseDir,
                    const std::vector<std::string>& overrides) {
  json raw = parseJsonText(text, label);
  if (!raw.is_object()) throw InputError(label + ": (top level): must be an object");

  // 1. --set size=NAME chooses the preset.
  for (const std::string& text : overrides) {
    const auto [path, value] = splitOverride(text);
    if (path == "size") setJsonPath(raw, path, value, "--set", false);
  }
  // 2. Presets.
  if (raw.contains("presets")) {
    const json presets = raw["presets"];
    raw.erase("presets");
    if (!presets.is_object()) throw InputError(label + ": presets: must be an object");
    if (!raw.contains("size") && presets.contains("production")) raw["size"] = "production";
    if (raw.contains("size")) {
      if (!raw["size"].is_string()) throw InputError(label + ": size: must be a string (got " + shortDump(raw["size"]) + ")");
      const std::string size = raw["size"].get<std::string>();
      if (!presets.contains(size)) {
        std::vector<std::string> names;
        for (auto it = presets.begin(); it != presets.end(); ++it) names.push_back(it.key());
        const std::string near = nearestWord(size, names);
        throw InputError(label + ": size: no preset named \"" + size + "\" (presets: " + joinWords(names) + ")" +
                         (near.empty() ? "" : " (did you mean '" + near + "'?)"));
      }
      const json& preset = presets[size];
      if (!preset.is_object()) throw InputError(label + ": presets." + size + ": must be an object");
      // A value the scene file sets itself beats the preset's (and is validated as given).
      const json explicitValues = raw;
      for (auto it = preset.begin(); it != preset.end(); ++it)
        if (!hasJsonPath(explicitValues, it.key()))
          setJsonPath(raw, it.key(), it.value(), label + ": presets." + size + ":", false);
    }
  }
  // 3. Parse with defaults.
  Scene scene = parseScene(raw, label, baseDir);
  // 4. Other overrides on the default-filled scene. An object set whole (say
  //    `whitewater={}`) is filled with its defaults at once, so that a later
  //    --set can reach its keys (`whitewater.rate_scale=2`).
  //    The support factor filled in from the solver type follows a --set of the type,
  //    unless the file, its preset or a --set gives it.
  bool changed = false;
  bool supportGiven = hasJsonPath(raw, "solver.support_factor");
  json full = sceneToJson(scene);
  for (const std::string& text : overrides) {
    const auto [path, value] = splitOverride(text);
    if (path == "size") continue;
    setJsonPath(full, path, value, "--set", true);
    changed = true;
    if (path == "solver.support_factor") supportGiven = true;
    if (path == "solver" && hasJsonPath(full, "solver.support_factor")) supportGiven = true;
    if (!value.empty() && value.front() == '{') full = sceneToJson(parseScene(full, label, baseDir));
  }
  if (changed && !supportGiven && full.contains("solver") && full["solver"].is_object())
    full["solver"].erase("support_factor");
  if (changed) scene = parseScene(full, label, baseDir);
  return scene;
}

Scene readResolvedScene(const fs::path& file) {
  fs::path baseDir = file.parent_path();
  if (baseDir.empty()) baseDir = ".";
  Context context{file.string(), baseDir};
  context.assetsOptional = true;
  return parseSceneIn(readJsonFile(file), context);
}

json writeResolvedScene(const Scene& scene, const fs::path& file, const std::vector<std::string>& meshHashes) {
  json resolved = resolvedScene(scene, file, meshHashes);
  writeTextAtomically(file, resolved.dump(2) + "\n");
  return resolved;
}

json resolvedScene(const Scene& scene, const fs::path& file, const std::vector<std::string>& meshHashes) {
  json resolved = sceneToJson(scene);
  std::error_code error;
  const fs::path folder = fs::absolute(file, error).parent_path().lexically_normal();
  json& obstacles = resolved["boundaries"]["obstacles"];
  for (std::size_t k = 0; k < scene.boundaries.obstacles.size(); ++k) {
    const Obstacle& obstacle = scene.boundaries.obstacles[k];
    const fs::path relative = fs::path(obstacle.mesh).lexically_relative(folder);
    if (!relative.empty()) obstacles[k]["mesh"] = relative.generic_string();
    obstacles[k]["mesh_hash"] = meshHashes.at(k);
  }
  return resolved;
}

} // namespace cascade::scene
