/// @file CoarseCorrection.h
/// @brief A two-level preconditioner for the DFSPH constant-density solve: the
///        Jacobi-scaled operator plus a coarse correction on aggregates of particles
///        (additive two-level Schwarz with piecewise-constant coarse space: Nicolaides
///        1987, "Deflation of conjugate gradients with applications to boundary value
///        problems", SIAM J. Numer. Anal. 24(2); Toselli & Widlund 2005, "Domain
///        Decomposition Methods", ch. 3; the aggregates are plain, not smoothed as in
///        Vanek, Mandel & Brezina 1996).
///
/// The solve's operator is A = dt^2 G^T G, with G the velocity change of a stiffness
/// vector (TimeStepDFSPH::velocityChange: (G s)_k = s_k G_k + sum_j s_j V grad W_kj) and
/// G^T the density rate of a velocity field. Its smooth modes (a deep column's
/// hydrostatic pressure) take CG O(depth) products. The coarse space holds the
/// stiffness fields that are constant on each aggregate (the particles in one cell of
/// a grid of cell size >= 2 h, so that two aggregates couple only through neighbouring
/// cells): Z with Z_ic = 1 where particle i is in aggregate c. The coarse operator is
/// the Galerkin product Z^T A Z = dt^2 (G Z)^T (G Z): the Gram matrix of the aggregates'
/// velocity-change fields, summed particle by particle over the few aggregates each
/// particle's neighbourhood touches (one pass over the pair terms, no operator products).
/// It is factored (sparse LDL^T, Eigen) once per solve.
///
/// In the solve's Jacobi-scaled unknowns (x = kappa / S_i, unit diagonal) the coarse
/// basis is Z_ic / S_i, and the preconditioner is M r = r + Z^ A_c^-1 Z^^T r on the free
/// set (r and the result 0 on the bound set): symmetric positive definite there, as PCG
/// needs, though A_c was taken over every particle, not the free set alone.
#pragma once

#include "libsph/Types.h"

#include <Eigen/SparseCholesky>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace cascade {

class CoarseCorrection {
public:
  /// One entry of a particle's row of G: the velocity change of particle k per unit
  /// stiffness of particle `source` (the pair's V grad W, or G_k for k itself).
  struct Coefficient {
    std::uint32_t source;
    Vec3r change;
  };

  /// Aggregates the n unknowns with Jacobi scaling S_i > 0 (scaling[i]; the scaled basis is
  /// 1 / S_i) into cells of cellSize at their positions, and factors the coarse operator
  /// dt2 (G Z)^T (G Z) with the rows of G from rowOf(k, out) for k in [0, n) (out
  /// cleared by the caller's function). Returns false (and apply() does nothing) when
  /// there is nothing to coarsen or the factorisation fails.
  using RowOf = std::function<void(std::size_t k, std::vector<Coefficient>& out)>;
  bool build(const Vec3r* position, const std::vector<double>& scaling, Real cellSize, double dt2, const RowOf& rowOf);

  /// z = r + Z^ A_c^-1 Z^^T r on the free set (bound[i] == 0); z holds r on entry and is 0
  /// on the bound set.
  void apply(std::vector<double>& z, const std::vector<char>& bound) const;

  bool active() const { return mActive; }
  std::size_t aggregates() const { return mCount; }

private:
  bool aggregate(const Vec3r* position, const std::vector<double>& scaling, Real cellSize);

  bool mActive = false;
  std::size_t mCount = 0;
  std::vector<std::int32_t> mAggregate;  ///< per unknown: its aggregate, -1 for none
  std::vector<std::int32_t> mCell;       ///< per aggregate: its cell (x, y, z), 3 entries
  std::vector<double> mWeight;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> mSolver;
  mutable Eigen::VectorXd mCoarse;
  mutable std::vector<Eigen::VectorXd> mPartial;
};

} // namespace cascade
