#include "surfacing/AnisotropicKernels.h"
#include "surfacing/detail/NeighborsWithin.h"

#include <Eigen/Eigenvalues>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace cascade::surfacing {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kKernelNormalization = 315.0 / (64.0 * kPi);  // of (1 - q^2)^3 on the unit ball

/// Cells deep inside the fluid: every cell within two cells of them holds at least
/// 60 % of a lattice's particle count. Their particles lie two cells (>= 2 neighbour
/// radii) from any sparser cell, so their neighbourhoods are complete and nearly
/// symmetric: Yu & Turk's kernel is the isotropic one there (eq. 15 with
/// s1 = s2 = s3; the centre shift of eq. 6 vanishes up to the lattice jitter), and
/// the neighbour sums can be skipped. Such kernels reach the surface only where it
/// is at least one cell away, so they only fill the inside of the band's leaves.
std::vector<std::uint8_t> deepCells(const ParticleGrid& grid, double spacing) {
  const std::size_t cells = grid.cellCount();
  const double lattice = std::pow(grid.cellSize() / spacing, 3);
  const std::uint32_t fullCount = std::uint32_t(std::max(1.0, std::ceil(0.6 * lattice)));
  std::vector<std::uint8_t> full(cells), eroded(cells);
  for (std::size_t cell = 0; cell < cells; ++cell) {
    const auto [begin, end] = grid.cellRange(cell);
    full[cell] = end - begin >= fullCount;
  }
  auto erode = [&](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells, 256), [&](const auto& range) {
      for (std::size_t cell = range.begin(); cell != range.end(); ++cell) {
        int count = 0;  // of the 27 cells around (itself included), those present and marked
        if (in[cell]) grid.forEachNeighborCell(grid.cellCoord(cell), [&](std::size_t neighbor) { count += in[neighbor]; });
        out[cell] = count == 27;
      }
    });
  };
  erode(full, eroded);
  erode(eroded, full);
  return full;
}

} // namespace

AnisotropicKernels computeAnisotropicKernels(const ParticleGrid& grid,
                                             const AnisotropicKernelSettings& settings) {
  const std::size_t n = grid.sortedPosition().size();
  const double s = settings.spacing;
  const double neighborRadius = settings.neighborRadius * s;
  const double support = settings.supportRadius * s;
  const double volume = s * s * s;
  // A full lattice neighbourhood within 2.1 spacings has 32 neighbours; "interior"
  // asks for 70 % of the continuum count (27) and a nearly centred neighbourhood.
  const double fullCount = 4.0 / 3.0 * kPi * std::pow(settings.neighborRadius, 3) * 0.7;

  AnisotropicKernels kernels;
  kernels.center.resize(n);
  kernels.transform.resize(n);
  kernels.weight.resize(n);
  kernels.halfExtent.resize(n);
  kernels.interior.resize(n);

  const std::vector<Vec3r>& position = grid.sortedPosition();
  const std::vector<std::uint8_t> deep = deepCells(grid, s);
  const Eigen::Matrix3f isotropic = (Eigen::Matrix3d::Identity() / support).cast<float>();
  const float isotropicWeight = float(volume * std::pow(support, -3) * kKernelNormalization);
  const float radius2 = float(neighborRadius * neighborRadius), inverseRadius = float(1 / neighborRadius);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.cellCount(), 16), [&](const auto& cells) {
    std::vector<std::uint32_t> near;
    std::vector<float> nearX, nearY, nearZ, nearR2;
    std::vector<std::uint32_t> nearWithin;
    for (std::size_t cell = cells.begin(); cell != cells.end(); ++cell) {
      if (deep[cell]) {  // complete, balanced neighbourhoods: the isotropic kernel, centred
        const auto [begin, end] = grid.cellRange(cell);
        for (std::uint32_t i = begin; i < end; ++i) {
          kernels.center[i] = position[i];
          kernels.transform[i] = isotropic;
          kernels.weight[i] = isotropicWeight;
          kernels.halfExtent[i] = Eigen::Vector3f::Constant(float(support));
          kernels.interior[i] = 1;
        }
        continue;
      }
      // Candidates from the 27 cells around this one, once for all its particles,
      // as float columns so that the distance pass below vectorises.
      near.clear();
      grid.forEachInNeighborCells(grid.cellCoord(cell), [&](std::uint32_t k) { near.push_back(k); });
      const std::size_t m = near.size();
      const std::size_t padded = m + detail::kNeighborsWithinPadding;
      near.resize(padded, 0);
      nearX.resize(padded);
      nearY.resize(padded);
      nearZ.resize(padded);
      nearR2.resize(padded);
      nearWithin.resize(padded);
      for (std::size_t c = 0; c < m; ++c) {
        const Eigen::Vector3f p = position[near[c]].template cast<float>();
        nearX[c] = p.x();
        nearY[c] = p.y();
        nearZ[c] = p.z();
      }
      const auto [begin, end] = grid.cellRange(cell);
      for (std::uint32_t i = begin; i < end; ++i) {
        const Eigen::Vector3d xi = position[i].cast<double>();
        const Eigen::Vector3f xf = position[i].cast<float>();
        const float px = xf.x(), py = xf.y(), pz = xf.z();
        const float* cx = nearX.data();
        const float* cy = nearY.data();
        const float* cz = nearZ.data();
        // The neighbours (candidate order) and their squared distances.
        const std::uint32_t* within = nearWithin.data();
        const float* r2s = nearR2.data();
        const std::size_t neighbors = detail::neighborsWithin(cx, cy, cz, near.data(), m, px, py, pz, radius2, i,
                                                              nearWithin.data(), nearR2.data());
        float weightSumF = 0;
        Eigen::Vector3f weightedSumF = Eigen::Vector3f::Zero();
        float xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
        int count = 0;
        for (std::size_t n = 0; n < neighbors; ++n) {
          const std::uint32_t c = within[n];
          const float r2 = r2s[n];
          const Eigen::Vector3f offset(cx[c] - px, cy[c] - py, cz[c] - pz);
          const float q = std::sqrt(r2) * inverseRadius;
          const float w = 1 - q * q * q;  // Yu & Turk eq. 11
          ++count;
          weightSumF += w;
          weightedSumF += w * offset;
          xx += w * offset.x() * offset.x();
          xy += w * offset.x() * offset.y();
          xz += w * offset.x() * offset.z();
          yy += w * offset.y() * offset.y();
          yz += w * offset.y() * offset.z();
          zz += w * offset.z() * offset.z();
        }
        const double weightSum = weightSumF;
        const Eigen::Vector3d weightedSum = weightedSumF.cast<double>();
        Eigen::Matrix3d secondMoment;
        secondMoment << xx, xy, xz, xy, yy, yz, xz, yz, zz;
        Eigen::Matrix3d G = Eigen::Matrix3d::Identity() / support;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        if (count >= settings.minNeighbors) {
          mean = weightedSum / weightSum;  // offset of the weighted mean, eq. 6 / 9
          const Eigen::Matrix3d covariance = secondMoment / weightSum - mean * mean.transpose();  // eq. 10
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
          eigen.computeDirect(covariance);  // closed form for 3x3
          Eigen::Vector3d sigma = eigen.eigenvalues().cwiseMax(0.0);  // ascending
          const double largest = sigma(2);
          if (largest > 0) {
            for (int k = 0; k < 3; ++k) sigma(k) = std::max(sigma(k), largest / settings.maxAnisotropy);
            Eigen::Vector3d stretch = sigma / std::cbrt(sigma.prod());  // unit determinant
            stretch = stretch.cwiseMin(settings.maxStretch);
            const Eigen::Matrix3d& axes = eigen.eigenvectors();
            G = axes * stretch.cwiseInverse().asDiagonal() * axes.transpose() / support;
          }
        } else {
          G = Eigen::Matrix3d::Identity() / (support * settings.isolatedScale);  // k_n
        }
        if (count > 0 && count < settings.minNeighbors) mean = weightedSum / weightSum;
        const Eigen::Vector3d center = xi + settings.centerSmoothing * mean;  // eq. 6
        // Support ellipsoid {d : |G d| < 1}: its AABB half size along axis k is |row k of G^-1|.
        const Eigen::Matrix3d inverse = G.inverse();
        Eigen::Vector3d half;
        for (int k = 0; k < 3; ++k) half(k) = inverse.row(k).norm();
        kernels.center[i] = center.cast<Real>();
        kernels.transform[i] = G.cast<float>();
        kernels.weight[i] = float(volume * G.determinant() * kKernelNormalization);
        kernels.halfExtent[i] = half.cast<float>();
        kernels.interior[i] =
            count >= fullCount && mean.norm() < 0.15 * s ? std::uint8_t(1) : std::uint8_t(0);
      }
    }
  });
  float maxHalf = 0;
  for (const Eigen::Vector3f& half : kernels.halfExtent) maxHalf = std::max(maxHalf, half.maxCoeff());
  kernels.maxHalfExtent = maxHalf;
  return kernels;
}

} // namespace cascade::surfacing
