/// @file PreviewRenderer.h
/// @brief Draws one preview still of a fluid surface mesh (or particles as
///        spheres) with the scene's solid geometry, headless, with OSMesa
///        (Mesa llvmpipe, an OpenGL 3.3 core context; no display, no GPU).
///
/// Passes per still (all in linear light, RGBA16F, multisampled):
///  1. shadow map of the key light (solids, fluid and particles as casters),
///     sampled with bilinear percentage-closer filtering (Reeves et al. 1987);
///  2. opaque pass: procedural sky (zenith/horizon gradient with a sun), a
///     ground plane fading into the horizon haze, the solids lit by the
///     lights plus a sky/ground hemisphere ambient, particles as ray-cast
///     sphere impostors coloured by speed, whitewater as white ones;
///  3. the fluid's nearest back faces into a depth texture;
///  4. the fluid's front faces: Schlick's Fresnel (F0 = 0.02) mixes a
///     reflection of the sky with the refracted opaque image (screen-space
///     offset by the view-space normal), attenuated by Beer-Lambert absorption
///     over the water thickness (back-face or opaque depth minus front depth)
///     with in-scattered deep-water colour; normalised Blinn-Phong sun glints;
///     the water has its own shadow map and lets 45 % of the key light through;
///  5. multisample resolve, filmic tone curve (Narkowicz's ACES fit), sRGB
///     encoding, optional supersampling box filter, read back to an Image.
/// The image alpha is the coverage of fluid, solids and particles (0 over sky
/// and ground), which tests use to measure silhouettes.
/// OSMesa/OpenGL headers stay in PreviewRenderer.cpp.
#pragma once

#include "libsph/io/TriangleMesh.h"
#include "render/Camera.h"
#include "render/Image.h"

#include <Eigen/Core>

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace cascade::render {

/// Particles drawn as spheres, coloured by speed.
struct ParticleSpheres {
  std::vector<Eigen::Vector3f> position;
  std::vector<float> speed;  ///< per particle, m/s; empty: all at rest
  float radius = 0.01f;      ///< sphere radius, m
  float speedScale = 1.0f;   ///< speed at the top (white) of the colour ramp, m/s
};

/// Whitewater drawn as small white spheres, one radius per kind (foam the
/// largest, so foam reads denser than spray).
struct WhitewaterSprites {
  std::vector<Eigen::Vector3f> position;  ///< by kind: spray, then foam, then bubbles
  std::array<std::size_t, 3> count{};     ///< per kind (spray, foam, bubble)
  std::array<float, 3> radius{};          ///< per kind, m
};

/// Appearance settings (linear RGB).
struct RenderLook {
  bool drawGround = true;  ///< a ground plane just below the stage
  bool drawSky = true;     ///< false: flat background colour
  Eigen::Vector3f background{0.5f, 0.6f, 0.7f};      ///< when drawSky is false
  Eigen::Vector3f deepWaterColor{0.015f, 0.10f, 0.13f};  ///< in-scattered colour of thick water
  /// Absorption (red, green, blue) per absorption length L = 0.1 x the stage
  /// height: transmittance through a thickness t is exp(-absorption * t / L).
  /// Stylised (real water is far clearer) so that thin sheets read as water.
  Eigen::Vector3f absorption{2.2f, 0.6f, 0.45f};
  float exposure = 0.85f;
};

/// What one still shows. Pointers may be null; meshes may be empty.
struct FrameScene {
  const TriangleMesh* fluid = nullptr;   ///< water surface, world coordinates, z up
  const TriangleMesh* solids = nullptr;  ///< tank, slope, obstacles (groups name them)
  const ParticleSpheres* particles = nullptr;
  const WhitewaterSprites* whitewater = nullptr;  ///< drawn with the opaque geometry, under the water's refraction
  Camera camera;
  std::vector<Light> lights;  ///< empty: defaultLights(camera)
  /// The stage: places the ground, fits the shadow map and the depth range,
  /// scales absorption. Empty: the bounds of what is drawn. Keep it fixed
  /// over an animation so ground and colours do not jump between frames.
  Box3f stage;
};

/// Bounds of the vertices of a mesh (empty box for an empty mesh).
Box3f meshBounds(const TriangleMesh& mesh);

class PreviewRenderer {
public:
  /// `samples`: 1 (no anti-aliasing), 2 or 4 multisampling; more than the GL
  /// limit (4 on llvmpipe) adds 2x2 supersampling on top of the maximum (up
  /// to 2560x1440 output). Throws std::runtime_error if OSMesa cannot give
  /// an OpenGL 3.3 core context.
  PreviewRenderer(int width, int height, int samples = 4, RenderLook look = {});
  ~PreviewRenderer();
  PreviewRenderer(const PreviewRenderer&) = delete;
  PreviewRenderer& operator=(const PreviewRenderer&) = delete;

  /// Renders a still (RGBA, sRGB colour, alpha = coverage of geometry).
  Image render(const FrameScene& scene);

  int width() const;
  int height() const;
  /// Multisamples times supersamples per pixel actually used.
  int effectiveSamples() const;
  /// "4.5 (Core Profile) Mesa 22.3.6, llvmpipe (...)".
  std::string glDescription() const;

private:
  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

} // namespace cascade::render
