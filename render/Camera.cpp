#include "render/Camera.h"

#include <algorithm>
#include <cmath>

namespace cascade::render {

namespace {
constexpr float kPi = 3.14159265358979f;
float radians(float degrees) { return degrees * kPi / 180.0f; }
} // namespace

Eigen::Vector3f Camera::right() const {
  Eigen::Vector3f side = forward().cross(up);
  if (side.squaredNorm() < 1e-12f) side = forward().cross(Eigen::Vector3f::UnitY());
  if (side.squaredNorm() < 1e-12f) side = forward().cross(Eigen::Vector3f::UnitX());
  return side.normalized();
}

Eigen::Matrix4f Camera::viewMatrix() const {
  const Eigen::Vector3f f = forward(), s = right(), u = s.cross(f);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.block<1, 3>(0, 0) = s.transpose();
  view.block<1, 3>(1, 0) = u.transpose();
  view.block<1, 3>(2, 0) = -f.transpose();
  view(0, 3) = -s.dot(position);
  view(1, 3) = -u.dot(position);
  view(2, 3) = f.dot(position);
  return view;
}

Eigen::Matrix4f Camera::projectionMatrix(float aspect, float nearPlane, float farPlane) const {
  const float focal = 1.0f / std::tan(radians(fovY) / 2.0f);
  Eigen::Matrix4f projection = Eigen::Matrix4f::Zero();
  projection(0, 0) = focal / aspect;
  projection(1, 1) = focal;
  projection(2, 2) = (farPlane + nearPlane) / (nearPlane - farPlane);
  projection(2, 3) = 2.0f * farPlane * nearPlane / (nearPlane - farPlane);
  projection(3, 2) = -1.0f;
  return projection;
}

Camera Camera::orbited(float angle) const {
  const Eigen::AngleAxisf rotation(angle, Eigen::Vector3f::UnitZ());
  Camera camera = *this;
  camera.position = target + rotation * (position - target);
  camera.up = rotation * up;
  return camera;
}

Camera autoFramingCamera(const Box3f& bounds, float aspect, float fovY, float margin) {
  Camera camera;
  camera.fovY = fovY;
  camera.up = Eigen::Vector3f::UnitZ();
  Box3f box = bounds;
  if (box.isEmpty()) box = Box3f(Eigen::Vector3f(-1, -1, -1), Eigen::Vector3f(1, 1, 1));
  const Eigen::Vector3f center = box.center();
  const float elevation = radians(25.0f), azimuth = radians(-35.0f);
  // Direction from the target to the camera: in front (-y), to the left, above.
  const Eigen::Vector3f toCamera(std::cos(elevation) * std::sin(azimuth),
                                 -std::cos(elevation) * std::cos(azimuth), std::sin(elevation));
  camera.target = center;
  camera.position = center + toCamera;  // provisional, for the camera frame
  const Eigen::Vector3f s = camera.right(), u = camera.trueUp();
  const float tanY = std::tan(radians(fovY) / 2.0f) * (1.0f - margin);
  const float tanX = tanY * aspect;
  // A corner p at depth d - p.toCamera must satisfy |p.s| <= tanX * depth and
  // |p.u| <= tanY * depth: solve for the smallest camera distance d.
  float distance = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f p = box.corner(Box3f::CornerType(corner)) - center;
    const float along = p.dot(toCamera);
    distance = std::max(distance, along + std::abs(p.dot(s)) / tanX);
    distance = std::max(distance, along + std::abs(p.dot(u)) / tanY);
  }
  distance = std::max(distance, 1e-3f);
  camera.position = center + toCamera * distance;
  return camera;
}

std::vector<Light> defaultLights(const Camera& camera) {
  Eigen::Vector3f forward = camera.forward();
  forward.z() = 0;
  if (forward.squaredNorm() < 1e-8f) forward = Eigen::Vector3f::UnitY();
  forward.normalize();
  const Eigen::Vector3f side = forward.cross(Eigen::Vector3f::UnitZ()).normalized();
  Light key;
  key.type = Light::Type::Directional;
  // Towards the sun: to the camera's left, behind the subject, high.
  const Eigen::Vector3f toSun = (-0.55f * side + 0.45f * forward + 1.1f * Eigen::Vector3f::UnitZ()).normalized();
  key.direction = -toSun;
  key.color = Eigen::Vector3f(1.0f, 0.96f, 0.9f);
  key.intensity = 1.0f;
  Light fill;
  fill.type = Light::Type::Directional;
  const Eigen::Vector3f toFill = (0.7f * side - 0.6f * forward + 0.35f * Eigen::Vector3f::UnitZ()).normalized();
  fill.direction = -toFill;
  fill.color = Eigen::Vector3f(0.75f, 0.85f, 1.0f);
  fill.intensity = 0.25f;
  return {key, fill};
}

} // namespace cascade::render
