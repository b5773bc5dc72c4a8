// The shared benchmark splash (BenchSplash.h): the column falling and spreading,
// the crown rising outward, droplets flying out, the pool's ring wave running out.
#include "BenchSplash.h"

#include <cmath>
#include <random>

namespace cascade::cli {

Splash splashParticles(double spacing) {
  Splash splash;
  std::vector<Vec3r>& points = splash.points;
  std::vector<Vec3r>& velocities = splash.velocities;
  std::mt19937 random(20261121);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto jitter = [&] { return (unit(random) - 0.5) * 0.1 * spacing; };
  Vec3d motion = Vec3d::Zero();  // the velocity of the part being added
  auto add = [&](double x, double y, double z) {
    points.emplace_back(Real(x + jitter()), Real(y + jitter()), Real(z + jitter()));
    velocities.push_back(motion.cast<Real>());
  };
  const double s = spacing;
  // Pool: 1.2 x 0.75 m, 15.4 cm deep, with a ring wave.
  const double poolX = 1.2, poolY = 0.75, poolDepth = 0.154;
  const Vec3d columnCenter(0.6, 0.375, 0);
  for (double x = 0.5 * s; x < poolX; x += s)
    for (double y = 0.5 * s; y < poolY; y += s) {
      const double r = std::hypot(x - columnCenter.x(), y - columnCenter.y());
      const double wave = std::exp(-std::pow((r - 0.3) / 0.06, 2));
      const double depth = poolDepth + 0.02 * wave;  // ring wave
      const Vec3d outward = r > 0 ? Vec3d(Vec3d(x - columnCenter.x(), y - columnCenter.y(), 0) / r) : Vec3d::Zero();
      motion = 0.6 * wave * outward;
      for (double z = 0.5 * s; z < depth; z += s) add(x, y, z);
    }
  // Collapsing column: a cylinder whose foot spreads out, on top of the pool.
  for (double z = poolDepth + 0.5 * s; z < poolDepth + 0.54; z += s) {
    const double radius = 0.09 + 0.12 * std::exp(-(z - poolDepth) / 0.05);
    for (double x = -radius; x <= radius; x += s)
      for (double y = -radius; y <= radius; y += s)
        if (x * x + y * y <= radius * radius) {
          motion = Vec3d(2.0 * x, 2.0 * y, -1.5);  // falling, its foot spreading
          add(columnCenter.x() + x, columnCenter.y() + y, z);
        }
  }
  // Crown: a thin sheet (one particle thick) rising from the ring wave.
  for (double z = poolDepth + 0.026; z < poolDepth + 0.156; z += s) {
    const double radius = 0.3 + 0.4 * (z - poolDepth - 0.026);
    const int n = int(2 * M_PI * radius / s);
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * (i + 0.5 * (int(z / s) % 2)) / n;
      motion = Vec3d(1.5 * std::cos(a), 1.5 * std::sin(a), 1.0);
      add(columnCenter.x() + radius * std::cos(a), columnCenter.y() + radius * std::sin(a), z);
    }
  }
  // 150 k airborne droplets around the column: single particles and small clusters.
  std::size_t droplets = 0;
  while (droplets < 150000) {
    const double a = 2 * M_PI * unit(random), r = 0.1 + 0.45 * unit(random);
    const double height = poolDepth + 0.036 + 0.45 * unit(random) * (1 - 0.6 * r);
    const double x = columnCenter.x() + r * std::cos(a), y = columnCenter.y() + r * std::sin(a);
    const int size = unit(random) < 0.7 ? 1 : 2 + int(6 * unit(random));
    motion = Vec3d(2.0 * std::cos(a), 2.0 * std::sin(a), 1.0 - 4.0 * (height - poolDepth));  // no draw: same points
    for (int k = 0; k < size && droplets < 150000; ++k, ++droplets)
      add(x + (k % 2) * s, y + ((k / 2) % 2) * s, height + (k / 4) * s);
  }
  return splash;
}

} // namespace cascade::cli
