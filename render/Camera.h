/// @file Camera.h
/// @brief A pinhole camera and light sources for preview stills (z up, as
///        scenes are), their OpenGL-convention matrices, and an automatic
///        framing camera that fits a bounding box into the view.
///
/// Matrices follow the OpenGL convention (right-handed eye space looking
/// down -z, clip-space depth in [-1, 1]); see the OpenGL 4.5 specification,
/// section 13.6 (coordinate transformations) for the perspective projection.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <vector>

namespace cascade::render {

using Box3f = Eigen::AlignedBox3f;

/// scene.json "camera": {"position", "target", "up", "fov" (vertical, degrees)}.
struct Camera {
  Eigen::Vector3f position{3, -4, 2};
  Eigen::Vector3f target{0, 0, 0};
  Eigen::Vector3f up{0, 0, 1};
  float fovY = 40.0f;  ///< vertical field of view, degrees

  /// World to eye transform (eye looks down -z).
  Eigen::Matrix4f viewMatrix() const;
  /// Perspective projection for the given aspect (width / height) and depth range.
  Eigen::Matrix4f projectionMatrix(float aspect, float nearPlane, float farPlane) const;
  /// Unit vectors of the camera frame in world space.
  Eigen::Vector3f forward() const { return (target - position).normalized(); }
  Eigen::Vector3f right() const;
  Eigen::Vector3f trueUp() const { return right().cross(forward()); }

  /// The camera turned about the vertical (z) axis through `target` by `radians`.
  Camera orbited(float radians) const;
};

/// scene.json "lights": {"type": "directional"|"point", "direction" or
/// "position", "color", "intensity"}. A directional light's direction is the
/// way its light travels (from the light into the scene), e.g. [-0.3, 0.2, -1]
/// for a high sun. A point light's intensity 1 gives the same irradiance as a
/// directional light of intensity 1 at the centre of the stage (inverse square law).
struct Light {
  enum class Type { Directional, Point };
  Type type = Type::Directional;
  Eigen::Vector3f direction{-0.4f, 0.3f, -1.0f};  ///< travel direction (directional)
  Eigen::Vector3f position{0, 0, 10};             ///< position (point)
  Eigen::Vector3f color{1, 1, 1};
  float intensity = 1.0f;
};

/// A camera looking at `bounds` from the front-left and above (elevation about
/// 25 degrees) at the distance where all eight corners fit into the frame
/// with a margin of `margin` (fraction of the half-width of the view).
Camera autoFramingCamera(const Box3f& bounds, float aspect, float fovY = 35.0f,
                         float margin = 0.06f);

/// A key light (sun, casts the shadows) and a soft fill, placed relative to
/// the camera so the stage is lit three-quarter from the front with the sun
/// high and slightly behind the subject (highlights on the water).
std::vector<Light> defaultLights(const Camera& camera);

} // namespace cascade::render
