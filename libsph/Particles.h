/// @file Particles.h
/// @brief Fluid particles as a structure of arrays.
///
/// Every per-particle attribute is its own contiguous array so that each
/// solver pass streams through exactly the memory it needs. `id` is stable
/// for a particle's whole life; the array index is not (particles are
/// reordered along a space-filling curve and removed when they leave).
/// Models the OpenVDB-style particle-list concept: size() and getPos().
#pragma once

#include "libsph/Types.h"

#include <cstddef>
#include <vector>

namespace cascade {

/// Reorders `values` so that values[k] becomes the old values[order[k]]
/// (order: a permutation of the indices, e.g. a search's zOrder()).
template <typename T>
void permuteArray(std::vector<T>& values, const std::vector<std::size_t>& order) {
  std::vector<T> result(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) result[k] = values[order[k]];
  values.swap(result);
}

struct Particles {
  std::vector<Vec3r> position;      ///< m
  std::vector<Vec3r> velocity;      ///< m/s
  std::vector<Real> density;        ///< kg/m^3, SEED (4)
  std::vector<Real> pressure;       ///< Pa, SEED (10)
  std::vector<ParticleId> id;       ///< stable identity, for caches and checksums

  Real mass = Real(0);              ///< kg, the same for every particle

  std::size_t size() const { return position.size(); }
  bool empty() const { return position.empty(); }

  /// Particle-list concept (OpenVDB tools): position of particle i.
  void getPos(std::size_t i, Vec3r& pos) const { pos = position[i]; }

  void resize(std::size_t n) {
    position.resize(n, Vec3r::Zero());
    velocity.resize(n, Vec3r::Zero());
    density.resize(n, Real(0));
    pressure.resize(n, Real(0));
    id.resize(n, 0);
  }

  void reserve(std::size_t n) {
    position.reserve(n);
    velocity.reserve(n);
    density.reserve(n);
    pressure.reserve(n);
    id.reserve(n);
  }

  /// Appends one particle at rest-state values (density and pressure zero).
  void add(const Vec3r& pos, const Vec3r& vel, ParticleId particleId) {
    position.push_back(pos);
    velocity.push_back(vel);
    density.push_back(Real(0));
    pressure.push_back(Real(0));
    id.push_back(particleId);
  }

  /// Keeps the first n particles.
  void truncate(std::size_t n) {
    if (n < size()) resize(n);
  }

  /// Appends particle i of `other`.
  void append(const Particles& other, std::size_t i) {
    position.push_back(other.position[i]);
    velocity.push_back(other.velocity[i]);
    density.push_back(other.density[i]);
    pressure.push_back(other.pressure[i]);
    id.push_back(other.id[i]);
  }

  /// Applies a permutation: new index k takes the particle at old index order[k].
  void permute(const std::vector<std::size_t>& order);

  /// Removes the particles whose flag is true, keeping the order of the rest.
  /// Returns how many were removed.
  std::size_t removeIf(const std::vector<char>& remove);
};

} // namespace cascade
