#include "render/RenderStage.h"

#include "whitewater/WhitewaterFile.h"

#include "libsph/Errors.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "render/ContactSheet.h"
#include "render/PreviewRenderer.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

namespace cascade::render {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// --- scene.json: only what the render stage needs -----------------------------

struct SceneView {
  std::optional<Camera> camera;
  std::vector<Light> lights;
  std::optional<Box3f> tank, domain;
  float spacing = 0;
  float gravity = 9.81f;
};

Eigen::Vector3f vector3(const json& value, const fs::path& file, const std::string& where) {
  if (!value.is_array() || value.size() != 3)
    throw InputError(file.string() + ": " + where + ": expected [x, y, z]");
  Eigen::Vector3f v;
  for (int k = 0; k < 3; ++k) {
    if (!value[std::size_t(k)].is_number()) throw InputError(file.string() + ": " + where + ": expected numbers");
    v[k] = value[std::size_t(k)].get<float>();
  }
  if (!v.allFinite()) throw InputError(file.string() + ": " + where + ": not finite");
  return v;
}

std::optional<Box3f> box(const json& parent, const char* key, const fs::path& file, const std::string& where) {
  if (!parent.is_object() || !parent.contains(key) || parent[key].is_null()) return std::nullopt;
  const json& value = parent[key];
  if (!value.is_object() || !value.contains("min") || !value.contains("max"))
    throw InputError(file.string() + ": " + where + ": expected {\"min\": [...], \"max\": [...]}");
  return Box3f(vector3(value["min"], file, where + ".min"), vector3(value["max"], file, where + ".max"));
}

SceneView readSceneView(const fs::path& file) {
  SceneView view;
  std::error_code error;
  if (!fs::is_regular_file(file, error)) return view;
  json scene;
  try {
    std::ifstream in(file);
    scene = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(file.string() + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  if (!scene.is_object()) throw InputError(file.string() + ": expected a JSON object");
  if (scene.contains("camera") && !scene["camera"].is_null()) {
    const json& c = scene["camera"];
    if (!c.is_object()) throw InputError(file.string() + ": camera: expected an object");
    Camera camera;
    if (c.contains("position")) camera.position = vector3(c["position"], file, "camera.position");
    if (c.contains("target")) camera.target = vector3(c["target"], file, "camera.target");
    if (c.contains("up")) camera.up = vector3(c["up"], file, "camera.up");
    if (c.contains("fov")) {
      if (!c["fov"].is_number()) throw InputError(file.string() + ": camera.fov: expected a number");
      camera.fovY = c["fov"].get<float>();
    }
    if (!(camera.fovY > 0 && camera.fovY < 179))
      throw InputError(file.string() + ": camera.fov: must be in (0, 179) degrees (got " +
                       std::to_string(camera.fovY) + ")");
    if ((camera.target - camera.position).norm() <= 0)
      throw InputError(file.string() + ": camera: position and target coincide");
    if (camera.up.norm() <= 0) throw InputError(file.string() + ": camera.up: must not be zero");
    view.camera = camera;
  }
  if (scene.contains("lights") && scene["lights"].is_array()) {
    for (std::size_t i = 0; i < scene["lights"].size(); ++i) {
      const json& l = scene["lights"][i];
      const std::string where = "lights[" + std::to_string(i) + "]";
      if (!l.is_object()) throw InputError(file.string() + ": " + where + ": expected an object");
      Light light;
      const std::string type = l.value("type", std::string("directional"));
      if (type == "directional") {
        light.type = Light::Type::Directional;
        if (l.contains("direction")) light.direction = vector3(l["direction"], file, where + ".direction");
        if (light.direction.norm() <= 0)
          throw InputError(file.string() + ": " + where + ".direction: must not be zero");
      } else if (type == "point") {
        light.type = Light::Type::Point;
        if (l.contains("position")) light.position = vector3(l["position"], file, where + ".position");
      } else {
        throw InputError(file.string() + ": " + where + ".type: expected \"directional\" or \"point\" (got \"" +
                         type + "\")");
      }
      if (l.contains("color")) light.color = vector3(l["color"], file, where + ".color");
      if (l.contains("intensity")) {
        if (!l["intensity"].is_number()) throw InputError(file.string() + ": " + where + ".intensity: expected a number");
        light.intensity = l["intensity"].get<float>();
      }
      view.lights.push_back(light);
    }
  }
  if (scene.contains("boundaries")) {
    view.tank = box(scene["boundaries"], "tank", file, "boundaries.tank");
    view.domain = box(scene["boundaries"], "domain", file, "boundaries.domain");
  }
  if (scene.contains("fluid") && scene["fluid"].is_object() && scene["fluid"].contains("spacing") &&
      scene["fluid"]["spacing"].is_number())
    view.spacing = scene["fluid"]["spacing"].get<float>();
  if (scene.contains("gravity") && scene["gravity"].is_array() && scene["gravity"].size() == 3) {
    const float g = vector3(scene["gravity"], file, "gravity").norm();
    if (g > 0) view.gravity = g;
  }
  return view;
}

// --- mesh axes ---------------------------------------------------------------------

/// File y-up (x, z, -y) back to world z-up: world = (x, -z, y).
void yUpToWorld(TriangleMesh& mesh) {
  for (auto& v : mesh.vertices) v = Eigen::Vector3f(v.x(), -v.z(), v.y());
  for (auto& n : mesh.normals) n = Eigen::Vector3f(n.x(), -n.z(), n.y());
  for (auto& u : mesh.velocities) u = Eigen::Vector3f(u.x(), -u.z(), u.y());
}

Box3f yUpToWorld(const Box3f& box) {
  if (box.isEmpty()) return box;
  Box3f out;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f v = box.corner(Box3f::CornerType(corner));
    out.extend(Eigen::Vector3f(v.x(), -v.z(), v.y()));
  }
  return out;
}

std::string lowercase(std::string text) {
  for (char& c : text) c = char(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

/// 'y', 'z' or 0 from the comment lines at the head of an OBJ file ("# ...") or
/// in a PLY header ("comment ...").
char objHeaderAxis(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  const bool ply = path.extension() == ".ply";
  for (int n = 0; n < 40 && std::getline(in, line); ++n) {
    if (line.empty()) continue;
    if (ply) {
      if (line.rfind("end_header", 0) == 0) break;
      if (line.rfind("comment", 0) != 0) continue;
    } else if (line[0] != '#') {
      break;
    }
    const std::string text = lowercase(line);
    for (const char axis : {'y', 'z'}) {
      const std::string a(1, axis);
      for (const std::string& pattern : {"up: " + a, "up:" + a, "up = " + a, "up=" + a, "up_axis " + a,
                                         "up_axis: " + a, "up axis: " + a, a + "-up", a + " up", "up " + a})
        if (text.find(pattern) != std::string::npos) return axis;
    }
  }
  return 0;
}

/// 'y', 'z' or 0 from OUT/manifest.json stages.surface.
char manifestAxis(const fs::path& manifest) {
  std::error_code error;
  if (!fs::is_regular_file(manifest, error)) return 0;
  try {
    std::ifstream in(manifest);
    const json document = json::parse(in);
    const json& surface = document.at("stages").at("surface");
    for (const char* key : {"obj_up_axis", "up_axis", "objUpAxis"})
      if (surface.contains(key) && surface[key].is_string()) {
        const std::string axis = lowercase(surface[key].get<std::string>());
        if (axis == "y" || axis == "z") return axis[0];
      }
    for (const char* key : {"obj_y_up", "objYUp", "y_up"})
      if (surface.contains(key) && surface[key].is_boolean()) return surface[key].get<bool>() ? 'y' : 'z';
    if (surface.contains("options") && surface["options"].is_object()) {
      const json& options = surface["options"];
      for (const char* key : {"obj_y_up", "objYUp", "y_up"})
        if (options.contains(key) && options[key].is_boolean()) return options[key].get<bool>() ? 'y' : 'z';
    }
  } catch (const std::exception&) {
  }
  return 0;
}

/// Fraction of `box`'s volume inside `reference` (flat boxes count by area).
double insideFraction(const Box3f& box, const Box3f& reference) {
  if (box.isEmpty() || reference.isEmpty()) return 0;
  const Eigen::Vector3f pad = 0.05f * reference.sizes() + Eigen::Vector3f::Constant(1e-6f);
  const Box3f grown(reference.min() - pad, reference.max() + pad);
  const Box3f overlap = box.intersection(grown);
  if (overlap.isEmpty()) return 0;
  double inside = 1, whole = 1;
  for (int k = 0; k < 3; ++k) {
    const double size = std::max(double(box.sizes()[k]), 1e-9);
    inside *= std::max(double(overlap.sizes()[k]), 1e-9);
    whole *= size;
  }
  return inside / whole;
}

// --- the stage ------------------------------------------------------------------------

struct FrameInput {
  int frame = 0;
  fs::path path;
};

std::string settingsSignature(const RenderOptions& options, char axis) {
  std::ostringstream text;
  text << "render v1 " << options.width << "x" << options.height << " samples " << options.samples << " mode "
       << (options.particles ? "particles" : "mesh") << " up " << axis << (options.whitewater ? "" : " no-whitewater");
  return text.str();
}

fs::file_time_type modified(const fs::path& path) {
  std::error_code error;
  const auto time = fs::last_write_time(path, error);
  return error ? fs::file_time_type::min() : time;
}

Box3f particleBounds(const ParticleFrame& frame) {
  Box3f box;
  for (const auto& p : frame.position) box.extend(p.cast<float>());
  return box;
}

/// Sphere radius: half the spacing (frame metadata, scene), else from the
/// number density within the bounds.
float sphereRadius(const ParticleFrame& frame, float sceneSpacing) {
  if (frame.spacing > 0) return 0.5f * float(frame.spacing);
  if (sceneSpacing > 0) return 0.5f * sceneSpacing;
  const Box3f box = particleBounds(frame);
  if (box.isEmpty() || frame.size() == 0) return 0.01f;
  const Eigen::Vector3f size = box.sizes().cwiseMax(1e-6f);
  return 0.5f * std::cbrt(size.prod() / float(frame.size()));
}

} // namespace

void RenderReport::throwIfFailed() const {
  if (errors.empty()) return;
  std::string message = errors.front();
  if (errors.size() > 1) message += " (and " + std::to_string(errors.size() - 1) + " more failed frames)";
  if (!rendered.empty() || !skipped.empty())
    message += "; the " + std::to_string(rendered.size() + skipped.size()) + " other frames are done";
  if (badInput) throw InputError(message);
  throw std::runtime_error(message);
}

RenderReport renderOutput(const fs::path& out, const RenderOptions& options,
                          const std::function<void(const std::string&)>& log) {
  using Clock = std::chrono::steady_clock;
  const auto stageStart = Clock::now();
  RenderReport report;
  if (options.width < 1 || options.height < 1 || options.width > 8192 || options.height > 8192)
    throw InputError("render: --width/--height must be within 1..8192 (got " + std::to_string(options.width) +
                     "x" + std::to_string(options.height) + ")");
  if (options.samples < 1 || options.samples > 64)
    throw InputError("render: --samples must be within 1..64 (got " + std::to_string(options.samples) + ")");
  if (options.turntableViews < 0 || options.turntableViews > 3600)
    throw InputError("render: --turntable must be within 0..3600 views");
  std::error_code error;
  if (!fs::is_directory(out, error)) throw InputError(out.string() + ": no such output directory");
  const OutputLayout layout(out);
  const SceneView scene = readSceneView(layout.scene());

  // Frames: every number in A-B when both bounds are given (a missing file is
  // then an error for that frame), else the files on disk within the range.
  std::vector<FrameInput> frames;
  {
    std::set<int> onDisk;
    std::vector<std::string> extensions = options.particles ? std::vector<std::string>{"vdb", "ply"}
                                                            : std::vector<std::string>{"obj", "ply"};
    const fs::path dir = options.particles ? layout.particlesDir() : layout.meshDir();
    for (const auto& extension : extensions)
      for (int frame : listFrames(dir, options.particles ? "particles" : "fluid", extension)) onDisk.insert(frame);
    auto pathOf = [&](int frame) {
      if (!options.particles) {  // the newer of fluid.NNNN.obj and .ply (the last surfacing's format)
        const fs::path obj = layout.mesh(frame), ply = layout.mesh(frame, "ply");
        if (!fs::exists(ply, error)) return obj;
        if (!fs::exists(obj, error)) return ply;
        return fs::last_write_time(ply, error) > fs::last_write_time(obj, error) ? ply : obj;
      }
      const fs::path vdb = layout.particles(frame), ply = layout.particlesPly(frame);
      return fs::exists(vdb, error) || !fs::exists(ply, error) ? vdb : ply;
    };
    if (options.frames.first && options.frames.last) {
      for (int frame = *options.frames.first; frame <= *options.frames.last; ++frame)
        frames.push_back({frame, pathOf(frame)});
    } else {
      for (int frame : onDisk)
        if (options.frames.contains(frame)) frames.push_back({frame, pathOf(frame)});
    }
    if (frames.empty())
      throw InputError(dir.string() + (options.particles ? ": no particle caches (particles.NNNN.vdb or .ply)"
                                                         : ": no fluid meshes (fluid.NNNN.obj or .ply; run `cascade surface`, "
                                                           "or render the particles with --particles)") +
                       " in the frame range");
  }

  // Solids, once for all frames (z-up world coordinates).
  TriangleMesh solids;
  const fs::path solidsPath = layout.root / "geometry" / "solids.obj";
  const bool hasSolids = fs::is_regular_file(solidsPath, error);
  if (hasSolids) solids = readObj(solidsPath);  // a broken solids file is bad input for every frame

  // Mesh axis (fluid meshes only).
  char axis = 'z';
  report.meshUp = "z";
  if (!options.particles) {
    if (options.meshUp == RenderOptions::MeshUp::Z) {
      axis = 'z', report.meshUp = "z (option)";
    } else if (options.meshUp == RenderOptions::MeshUp::Y) {
      axis = 'y', report.meshUp = "y (option)";
    } else {
      char found = 0;
      std::string how;
      for (const auto& input : frames)
        if (fs::is_regular_file(input.path, error)) {
          found = objHeaderAxis(input.path);
          how = "OBJ header comment";
          break;
        }
      if (!found) {
        found = manifestAxis(layout.manifest());
        how = "manifest.json";
      }
      if (!found) {
        // Which orientation fits the scene's box? Use the first readable mesh.
        std::optional<Box3f> reference = scene.domain ? scene.domain : scene.tank;
        if (!reference && hasSolids && !solids.empty()) reference = meshBounds(solids);
        if (reference) {
          for (const auto& input : frames) {
            if (!fs::is_regular_file(input.path, error)) continue;
            try {
              const Box3f bounds = meshBounds(readMesh(input.path));
              if (bounds.isEmpty()) continue;
              const double zScore = insideFraction(bounds, *reference);
              const double yScore = insideFraction(yUpToWorld(bounds), *reference);
              if (std::abs(zScore - yScore) > 0.05) {
                found = zScore > yScore ? 'z' : 'y';
                how = "fits the scene box";
              }
            } catch (const InputError&) {
            }
            break;
          }
        }
      }
      if (!found) {
        found = 'y';
        how = "surfacing default";
      }
      axis = found;
      report.meshUp = std::string(1, axis) + " (" + how + ")";
    }
  }

  auto loadMesh = [&](const fs::path& path) {
    TriangleMesh mesh = readMesh(path);
    const std::size_t n = mesh.vertices.size();
    for (const auto& t : mesh.triangles)
      if (t[0] >= n || t[1] >= n || t[2] >= n) throw InputError(path.string() + ": face index out of range");
    for (const auto& v : mesh.vertices)
      if (!v.allFinite()) throw InputError(path.string() + ": vertex coordinate not finite");
    if (axis == 'y') yUpToWorld(mesh);
    return mesh;
  };
  auto loadParticles = [&](const fs::path& path, float speedScale) {
    const ParticleFrame frame = readParticleFrame(path);
    ParticleSpheres spheres;
    spheres.position.reserve(frame.size());
    for (const auto& p : frame.position) spheres.position.push_back(p.cast<float>());
    for (const auto& v : frame.velocity) spheres.speed.push_back(float(v.norm()));
    spheres.radius = sphereRadius(frame, scene.spacing);
    spheres.speedScale = speedScale;
    return spheres;
  };

  // The stage, fixed over the frames: solids, else the tank, else the first
  // and last frames that load.
  Box3f stage;
  if (hasSolids && !solids.empty()) stage = meshBounds(solids);
  else if (scene.tank) stage = *scene.tank;
  if (scene.domain && !stage.isEmpty()) {  // very large planes: keep the stage to the domain
    const Eigen::Vector3f pad = 0.1f * scene.domain->sizes();
    const Box3f clipped = stage.intersection(Box3f(scene.domain->min() - pad, scene.domain->max() + pad));
    if (!clipped.isEmpty()) stage = clipped;
  }
  Box3f framing = stage;
  if (stage.isEmpty() || !scene.camera) {
    for (const FrameInput* input : {&frames.front(), &frames.back()}) {
      try {
        if (options.particles) {
          framing.extend(particleBounds(readParticleFrame(input->path)));
        } else {
          framing.extend(meshBounds(loadMesh(input->path)));
        }
      } catch (const InputError&) {
      }
    }
    if (stage.isEmpty()) stage = framing;
  }
  const float aspect = float(options.width) / float(options.height);
  const Camera camera = scene.camera ? *scene.camera : autoFramingCamera(framing, aspect);
  const std::vector<Light> lights = scene.lights;  // empty: the renderer's defaults
  const float stageHeight = stage.isEmpty() ? 1.0f : std::max(stage.sizes().z(), 0.05f);
  const float speedScale = std::sqrt(2.0f * scene.gravity * stageHeight);

  // Made on first use (none if all frames are up to date). One that cannot be made (no
  // OSMesa, no GL 3.3 context) is no frame's fault: the stage stops with that one error.
  struct RendererUnavailable : std::runtime_error {
    using std::runtime_error::runtime_error;
  };
  std::unique_ptr<PreviewRenderer> rendererStorage;
  auto renderer = [&]() -> PreviewRenderer& {
    if (!rendererStorage) {
      try {
        rendererStorage = std::make_unique<PreviewRenderer>(options.width, options.height, options.samples);
      } catch (const std::exception& e) {
        throw RendererUnavailable(e.what());
      }
      report.glDescription = rendererStorage->glDescription();
    }
    return *rendererStorage;
  };
  const std::string signature = settingsSignature(options, axis);
  const PngText text = {{"Software", "Cascade render"}, {"cascade-render", signature}};

  auto frameScene = [&](const TriangleMesh* fluid, const ParticleSpheres* spheres, const Camera& view,
                        const TriangleMesh* frameSolids = nullptr, const WhitewaterSprites* whitewater = nullptr) {
    FrameScene frameScene;
    frameScene.fluid = fluid;
    frameScene.particles = spheres;
    frameScene.whitewater = whitewater;
    frameScene.solids = frameSolids ? frameSolids : hasSolids ? &solids : nullptr;
    frameScene.camera = view;
    frameScene.lights = lights;
    frameScene.stage = stage;
    return frameScene;
  };

  std::vector<ContactSheetTile> tiles;
  const int thumbnailWidth = std::min(options.width, 640);
  const int thumbnailHeight = std::max(1, int(std::lround(double(thumbnailWidth) * options.height / options.width)));
  double renderSeconds = 0;
  bool otherFailure = false;
  const auto inputsTime = std::max(hasSolids ? modified(solidsPath) : fs::file_time_type::min(),
                                   modified(layout.scene()));
  // Frames whose PNG is up to date (newer than its inputs, same settings) are skipped.
  std::vector<std::size_t> todo;
  for (std::size_t index = 0; index < frames.size(); ++index) {
    const FrameInput& input = frames[index];
    const fs::path target = layout.render(input.frame);
    // Moving solids: this frame's solids (geometry/solids.NNNN.obj) are an input too.
    const fs::path frameSolids = layout.solids(input.frame);
    const auto solidsTime = fs::is_regular_file(frameSolids, error) ? modified(frameSolids) : fs::file_time_type::min();
    const fs::path whitewater = layout.whitewater(input.frame);
    const auto whitewaterTime = options.whitewater && fs::is_regular_file(whitewater, error) ? modified(whitewater)
                                                                                          : fs::file_time_type::min();
    if (!options.force && fs::is_regular_file(input.path, error) && fs::is_regular_file(target, error) &&
        modified(target) >= std::max({modified(input.path), inputsTime, solidsTime, whitewaterTime})) {
      const PngText stored = readPngText(target);
      const auto found = stored.find("cascade-render");
      if (found != stored.end() && found->second == signature) {
        report.skipped.push_back(input.frame);
        if (options.contactSheet) {
          try {
            tiles.push_back({input.frame, resizeImage(readPng(target), thumbnailWidth, thumbnailHeight)});
          } catch (const InputError&) {
          }
        }
        if (log) log("render: frame " + std::to_string(input.frame) + " up to date (" + target.string() + ")");
        continue;
      }
    }
    todo.push_back(index);
  }

  // Render; the next frame's file is read on another thread meanwhile.
  struct Loaded {
    std::optional<TriangleMesh> fluid;
    std::optional<ParticleSpheres> spheres;
    std::optional<WhitewaterSprites> whitewater;
    std::optional<TriangleMesh> solids;  ///< the frame's own, when solids move
  };
  auto loadFrameSolids = [&](int frame) -> std::optional<TriangleMesh> {
    std::error_code missing;
    const fs::path path = layout.solids(frame);
    if (!fs::is_regular_file(path, missing)) return std::nullopt;
    return readObj(path);
  };
  // Whitewater (OUT/whitewater/whitewater.NNNN.vdb), when there is one: white
  // spheres, foam the largest (0.35 spacings), bubbles 0.25, spray 0.2.
  auto loadWhitewater = [&](int frame) -> std::optional<WhitewaterSprites> {
    std::error_code missing;
    const fs::path path = layout.whitewater(frame);
    if (!options.whitewater || !fs::is_regular_file(path, missing)) return std::nullopt;
    const whitewater::WhitewaterFrame diffuse = whitewater::readWhitewaterVdb(path);
    WhitewaterSprites sprites;
    sprites.count = diffuse.counts();
    sprites.position.resize(diffuse.particles.size());
    std::array<std::size_t, 3> next{0, sprites.count[0], sprites.count[0] + sprites.count[1]};
    for (std::size_t i = 0; i < diffuse.particles.size(); ++i)
      sprites.position[next[std::size_t(diffuse.type[i])]++] = diffuse.particles.position[i].cast<float>();
    const float spacing = float(diffuse.spacing > 0 ? diffuse.spacing : scene.spacing > 0 ? scene.spacing : 0.01);
    sprites.radius = {0.2f * spacing, 0.35f * spacing, 0.25f * spacing};
    return sprites;
  };
  auto load = [&](std::size_t index) {
    const FrameInput& input = frames[index];
    std::error_code missing;
    if (!fs::is_regular_file(input.path, missing))
      throw InputError(input.path.string() + ": no such file (frame " + std::to_string(input.frame) + ")");
    Loaded loaded;
    if (options.particles) loaded.spheres = loadParticles(input.path, speedScale);
    else loaded.fluid = loadMesh(input.path);
    loaded.solids = loadFrameSolids(input.frame);
    loaded.whitewater = loadWhitewater(input.frame);
    return loaded;
  };
  std::future<Loaded> next;
  if (!todo.empty()) next = std::async(std::launch::async, load, todo.front());
  for (std::size_t k = 0; k < todo.size(); ++k) {
    const std::size_t index = todo[k];
    const FrameInput& input = frames[index];
    const fs::path target = layout.render(input.frame);
    const auto frameStart = Clock::now();
    try {
      std::future<Loaded> current = std::move(next);
      if (k + 1 < todo.size()) next = std::async(std::launch::async, load, todo[k + 1]);
      const Loaded loaded = current.get();
      const Image image = renderer().render(frameScene(loaded.fluid ? &*loaded.fluid : nullptr,
                                                     loaded.spheres ? &*loaded.spheres : nullptr, camera,
                                                     loaded.solids ? &*loaded.solids : nullptr,
                                                     loaded.whitewater ? &*loaded.whitewater : nullptr));
      writePng(target, image, false, text);
      report.written.push_back(target);
      report.rendered.push_back(input.frame);
      const double seconds = std::chrono::duration<double>(Clock::now() - frameStart).count();
      renderSeconds += seconds;
      if (options.contactSheet) tiles.push_back({input.frame, resizeImage(image, thumbnailWidth, thumbnailHeight)});
      if (log) {
        const double mean = renderSeconds / double(report.rendered.size());
        char line[512];
        std::snprintf(line, sizeof line, "render: frame %d (%zu/%zu) %.2f s, ETA %.0f s -> %s", input.frame, k + 1,
                      todo.size(), seconds, mean * double(todo.size() - k - 1), target.string().c_str());
        log(line);
      }
    } catch (const InputError& e) {
      report.errors.push_back(e.what());
      if (log) log(e.what());
    } catch (const RendererUnavailable&) {
      throw;
    } catch (const std::exception& e) {
      otherFailure = true;
      report.errors.push_back(input.path.string() + ": " + e.what());
      if (log) log(report.errors.back());
    }
  }
  if (options.contactSheet)  // in frame order
    std::sort(tiles.begin(), tiles.end(), [](const auto& a, const auto& b) { return a.frame < b.frame; });
  report.badInput = !report.errors.empty() && !otherFailure;
  if (!report.rendered.empty()) report.secondsPerFrame = renderSeconds / double(report.rendered.size());

  if (options.contactSheet && !tiles.empty()) {
    const fs::path sheet = layout.renderDir() / "contact_sheet.png";
    writePng(sheet, makeContactSheet(tiles, options.contactSheetColumns, options.contactSheetWidth), false, text);
    report.written.push_back(sheet);
    if (log) log("render: contact sheet of " + std::to_string(tiles.size()) + " frames -> " + sheet.string());
  }

  if (options.turntableViews > 0) {
    // The first frame of the range that loads, seen from views around the target.
    for (const auto& input : frames) {
      try {
        std::optional<TriangleMesh> fluid;
        std::optional<ParticleSpheres> spheres;
        if (options.particles) spheres = loadParticles(input.path, speedScale);
        else fluid = loadMesh(input.path);
        const std::optional<TriangleMesh> frameSolids = loadFrameSolids(input.frame);
        for (int view = 0; view < options.turntableViews; ++view) {
          const Camera orbit = camera.orbited(float(2.0 * 3.14159265358979 * view / options.turntableViews));
          const Image image = renderer().render(frameScene(fluid ? &*fluid : nullptr, spheres ? &*spheres : nullptr, orbit,
                                                           frameSolids ? &*frameSolids : nullptr));
          const fs::path target = layout.renderDir() / ("turntable." + OutputLayout::pad(view + 1) + ".png");
          writePng(target, image, false, text);
          report.written.push_back(target);
        }
        if (log)
          log("render: turntable of frame " + std::to_string(input.frame) + ", " +
              std::to_string(options.turntableViews) + " views -> " + (layout.renderDir() / "turntable.NNNN.png").string());
        break;
      } catch (const InputError&) {
        continue;  // already reported for the frame itself
      }
    }
  }
  report.seconds = std::chrono::duration<double>(Clock::now() - stageStart).count();
  return report;
}

} // namespace cascade::render
