/// @file Probes.h
/// @brief The probes of a scene as free functions over a particle list
///        (concept: size() and getPos(i, pos); Particles and ParticleFrame
///        model it): water height at (x, y), pressure at a boundary point,
///        force on an obstacle, surge front along a direction, fluid velocity
///        at a point.
///
/// "Isolated droplets" are particles with fewer than `minNeighbors` other
/// particles within 2 spacings; the height and front probes ignore them.
/// The fluid surface is taken half a spacing beyond the outermost particle
/// centre (a particle stands for a cube of one spacing).
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/Particles.h"
#include "libsph/Types.h"

#include <limits>
#include <string>
#include <vector>

namespace cascade {

class Simulation;

/// For each particle, whether it belongs to the bulk: at least minNeighbors
/// others within `radius`. Uses a cell grid; O(N).
std::vector<char> bulkParticles(const std::vector<Vec3r>& positions, Real radius, int minNeighbors);

/// Surge front: max over bulk particles of dot(position, direction) + spacing/2
/// (direction normalised). NaN if there is no bulk particle.
double surgeFront(const std::vector<Vec3r>& positions, const Vec3r& direction, Real spacing,
                  int minNeighbors = 3);

/// Water height at (x, y): the highest bulk particle within a horizontal
/// distance of one spacing, plus spacing/2 (z of the free surface, m).
/// NaN if no water is above or below the point.
double waterHeight(const std::vector<Vec3r>& positions, double x, double y, Real spacing,
                   int minNeighbors = 3);

/// Pressure at a point on a boundary: the Shepard-normalised SPH average of
/// the particles within supportRadius (poly6 weights, SEED (4)/(7)) of
/// p_j + rho_j g . (point - x_j), i.e. each pressure extrapolated
/// hydrostatically to the point (Adami et al. 2012). 0 if no particle is near.
double pressureAt(const Particles& particles, const Vec3r& point, Real supportRadius,
                  const Vec3r& gravity);
/// The same over the particles [begin, end) only: those within supportRadius of the
/// point, found through a grid (ProbeNeighborhoods), so a sample costs the particles
/// near the point, not all of them.
double pressureAt(const Particles& particles, const Vec3r& point, Real supportRadius, const Vec3r& gravity,
                  const std::uint32_t* begin, const std::uint32_t* end);

/// Pressure over a transducer's face, a disc of `radius` centred at `center` with unit
/// `normal`: the area average of pressureAt (each point Shepard-normalised, 0 where no
/// fluid is within supportRadius, as a dry part of the face reads) over the 7-point
/// disc rule exact for cubics (centre 1/4; six points at sqrt(2/3) radius, 1/8 each;
/// Stroud 1971, S2:3-1). The list must hold the particles within supportRadius + radius.
/// radius 0 is pressureAt at the centre.
double pressureOverDisc(const Particles& particles, const Vec3r& center, const Vec3r& normal, Real radius,
                        Real supportRadius, const Vec3r& gravity, const std::uint32_t* begin, const std::uint32_t* end);

/// Fluid velocity at a point: the Shepard-normalised SPH average of v_j with poly6
/// weights over the listed particles (within supportRadius). False (velocity
/// untouched) if no fluid is within supportRadius.
bool velocityAt(const Particles& particles, const Vec3r& point, Real supportRadius, const std::uint32_t* begin,
                const std::uint32_t* end, Vec3d& velocity);

/// The particles within `radius` of each of a few probe points: one grid built over
/// the particles (O(N)), then one query per point; list k is for points[k].
NeighborLists probeNeighborhoods(const Particles& particles, const std::vector<Vec3r>& points, Real radius);

/// Force the fluid exerts on the named boundary in the simulation's last step, N.
/// Throws std::invalid_argument for an unknown name.
Vec3d obstacleForce(const Simulation& simulation, const std::string& obstacle);

} // namespace cascade
