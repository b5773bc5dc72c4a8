/// @file DiffuseParticles.h
/// @brief Diffuse (whitewater) particles: spray, foam and bubbles (Ihmsen,
///        Akinci, Akinci & Teschner 2012, "Unified spray, foam and bubbles for
///        particle-based fluids", The Visual Computer 28), as arrays.
#pragma once

#include "libsph/Types.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace cascade::whitewater {


/// What a diffuse particle is, by its fluid neighbour count (Ihmsen 2012 sec. 5):
/// the values of the "type" attribute in whitewater files.
enum class DiffuseType : std::uint8_t { Spray = 0, Foam = 1, Bubble = 2 };
constexpr int kDiffuseTypeCount = 3;

/// "spray", "foam", "bubble".
const char* diffuseTypeName(DiffuseType type);

/// Spray below `sprayNeighbors` fluid neighbours, bubble above `bubbleNeighbors`, else foam.
inline DiffuseType classifyDiffuse(std::size_t fluidNeighbors, int sprayNeighbors, int bubbleNeighbors) {
  if (fluidNeighbors < std::size_t(sprayNeighbors)) return DiffuseType::Spray;
  if (fluidNeighbors > std::size_t(bubbleNeighbors)) return DiffuseType::Bubble;
  return DiffuseType::Foam;
}

/// Diffuse particles, structure of arrays: 32 bytes a particle. Their type is
/// not kept: it follows from where a particle is, so it is computed when needed.
struct DiffuseParticles {
  std::vector<Vec3r> position;    ///< m, world (scene) coordinates
  std::vector<Vec3r> velocity;    ///< m/s
  std::vector<std::uint32_t> id;  ///< births numbered in order over a whole run
  std::vector<float> age;         ///< s since birth

  std::size_t size() const { return position.size(); }
  void reserve(std::size_t count);
  void push_back(const Vec3r& x, const Vec3r& v, std::uint32_t identifier, float ageSeconds);
  void append(const DiffuseParticles& other);
  /// Particle k becomes the old particle order[k] (a permutation).
  void permute(const std::vector<std::size_t>& order);
  /// Keeps the particles with keep[i] != 0, in order.
  void keepWhere(const std::vector<std::uint8_t>& keep);
  /// Bytes per particle held by the arrays.
  static constexpr std::size_t bytesPerParticle() { return 2 * sizeof(Vec3r) + sizeof(std::uint32_t) + sizeof(float); }
};

} // namespace cascade::whitewater
