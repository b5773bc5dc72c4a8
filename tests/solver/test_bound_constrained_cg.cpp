// BoundConstrainedCG.h: the primal-dual active set method with CG inner solves, on
// problems whose answer is known exactly.
//
// 1. The discrete obstacle problem of a 1-D Laplacian (A = tridiag(-1, 2, -1), scaled
//    to unit diagonal) with a load b that pushes up at both ends and down in the middle,
//    from a feasible start off the bound: checked by the KKT conditions themselves
//    (x >= 0, g >= 0, x g = 0) and against projected Gauss-Seidel run to convergence.
// 2. Without active bounds (b > 0 everywhere so x > 0) it is plain CG: the solution
//    of A x = b to the tolerance, found in at most n products (exact arithmetic: n).
// 3. The same iterates on 1 and on many threads (fixed-order sums).
// 4. Inexact inner solves (each CG phase on a bound set still changing stops at a
//    tenfold cut) reach the same KKT point as exact ones, in fewer products; with no
//    bound active they resume one CG, the same iterates bit for bit.
// 5. Preconditioned (a two-level preconditioner: identity plus an exact coarse solve on
//    aggregates of consecutive nodes, as CoarseCorrection.h does for DFSPH), the same
//    KKT point in fewer products.
#include "libsph/solver/BoundConstrainedCG.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

using namespace cascade;

namespace {

/// A = tridiag(-1/2, 1, -1/2) (the 1-D Laplacian scaled to unit diagonal), Dirichlet ends.
struct Laplacian1D {
  double tolerance = 1e-12, maxResidual = 1e-12;
  double coupling = 0.5;  // below 1/2: a shifted Laplacian, better conditioned
  void product(const std::vector<double>& p, std::vector<double>& out, double& pAp) const {
    const std::size_t n = p.size();
    pAp = 0;
    for (std::size_t i = 0; i < n; ++i) {
      out[i] = p[i] - coupling * ((i > 0 ? p[i - 1] : 0.0) + (i + 1 < n ? p[i + 1] : 0.0));
      pAp += p[i] * out[i];
    }
  }
  double weight(std::size_t) const { return 1.0; }
};

std::vector<double> gradientOf(const Laplacian1D& A, const std::vector<double>& x, const std::vector<double>& b) {
  std::vector<double> g(x.size());
  double unused = 0;
  A.product(x, g, unused);
  for (std::size_t i = 0; i < x.size(); ++i) g[i] -= b[i];
  return g;
}

/// Projected Gauss-Seidel to convergence: the reference answer.
std::vector<double> projectedGaussSeidel(const std::vector<double>& b, double coupling = 0.5) {
  const std::size_t n = b.size();
  std::vector<double> x(n, 0.0);
  for (int sweep = 0; sweep < 200000; ++sweep) {
    double change = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double neighbours = coupling * ((i > 0 ? x[i - 1] : 0.0) + (i + 1 < n ? x[i + 1] : 0.0));
      const double next = std::max(0.0, b[i] + neighbours);
      change = std::max(change, std::abs(next - x[i]));
      x[i] = next;
    }
    if (change < 1e-15) break;
  }
  return x;
}

} // namespace

TEST(BoundConstrainedCG, SolvesTheObstacleProblemToItsKktPoint) {
  const std::size_t n = 64;
  std::vector<double> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = std::sin(3.0 * M_PI * double(i) / double(n - 1)) * 0.01 - 0.003;  // up, down, up
  Laplacian1D A;
  std::vector<double> x(n, 0.05);  // a feasible start off the bound: the bound set must be found
  std::vector<double> g = gradientOf(A, x, b);
  const BoundConstrainedResult result = solveBoundConstrained(A, x, g, 10000);
  EXPECT_TRUE(result.converged);
  EXPECT_GT(result.activeSetSteps, 0);  // the bound set had to be found
  const std::vector<double> exact = gradientOf(A, x, b);
  int bound = 0;
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_GE(x[i], 0.0) << i;
    EXPECT_GE(exact[i], -1e-11) << i;               // no compression left where x = 0
    EXPECT_LT(std::abs(x[i] * exact[i]), 1e-12) << i;  // complementarity
    EXPECT_NEAR(g[i], exact[i], 1e-11) << i;        // the updated gradient is A x - b
    bound += x[i] == 0.0 ? 1 : 0;
  }
  EXPECT_GT(bound, 5);       // the downward load leaves a stretch at the bound
  EXPECT_LT(bound, int(n) - 5);
  const std::vector<double> reference = projectedGaussSeidel(b);
  for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(x[i], reference[i], 1e-9) << i;
}

TEST(BoundConstrainedCG, IsConjugateGradientsWhenNoBoundIsActive) {
  const std::size_t n = 40;
  std::vector<double> b(n, 0.01);
  Laplacian1D A;
  std::vector<double> x(n, 0.0);
  std::vector<double> g = gradientOf(A, x, b);
  const BoundConstrainedResult result = solveBoundConstrained(A, x, g, 10000);
  EXPECT_TRUE(result.converged);
  EXPECT_LE(result.products, int(n) + 2);  // CG: n steps in exact arithmetic (+ the final check)
  // The inexact phases resume the same CG when no bound changes: the exact-phase iterates.
  std::vector<double> exactX(n, 0.0);
  std::vector<double> exactG = gradientOf(A, exactX, b);
  const BoundConstrainedResult exact = solveBoundConstrained(A, exactX, exactG, 10000, 0.0);
  EXPECT_EQ(exact.products, result.products);
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(x[i], exactX[i]) << i;
  // Exact: x_i = 0.02 (i + 1)(n - i) / 2 solves tridiag(-1/2, 1, -1/2) x = 0.01 with x_0 = x_{n+1} = 0.
  for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(x[i], 0.01 * double(i + 1) * double(n - i), 1e-9) << i;
}

TEST(BoundConstrainedCG, GivesTheSameIteratesOnAnyNumberOfThreads) {
  const std::size_t n = 5000;  // several fixed-order chunks
  std::vector<double> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = std::sin(7.0 * M_PI * double(i) / double(n - 1)) * 0.01;
  auto solve = [&](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
    Laplacian1D A;
    A.tolerance = 1e-6;
    A.maxResidual = 1e-9;
    std::vector<double> x(n, 0.0);
    std::vector<double> g = gradientOf(A, x, b);
    solveBoundConstrained(A, x, g, 400);
    return x;
  };
  const std::vector<double> one = solve(1), many = solve(8);
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(one[i], many[i]) << i;
}

TEST(BoundConstrainedCG, InexactPhasesReachTheSameKktPointInFewerProducts) {
  // Loads up and down along a long 1-D obstacle problem: many stretches at the bound,
  // found over several outer steps.
  const std::size_t n = 2000;
  std::vector<double> b(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = double(i) / double(n - 1);
    b[i] = 0.002 * std::sin(11.0 * M_PI * s) + 0.001 * std::sin(37.0 * M_PI * s) - 0.0005;
  }
  auto solve = [&](double phaseReduction, BoundConstrainedResult& result) {
    Laplacian1D A;
    A.coupling = 0.49;  // condition number about 100, as the Jacobi-scaled SPH operator's
    A.tolerance = 1e-8;
    A.maxResidual = 1e-10;
    std::vector<double> x(n, 0.01);
    std::vector<double> g = gradientOf(A, x, b);
    result = solveBoundConstrained(A, x, g, 100000, phaseReduction);
    const std::vector<double> exact = gradientOf(A, x, b);
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_GE(x[i], 0.0) << i;
      EXPECT_GE(exact[i], -1e-10) << i;
      EXPECT_LE(x[i] > 0 ? std::abs(exact[i]) : 0.0, 1e-10) << i;  // the stop test, on the true gradient
    }
    return x;
  };
  BoundConstrainedResult exactResult, inexactResult;
  const std::vector<double> exact = solve(0.0, exactResult), inexact = solve(kPhaseReduction, inexactResult);
  EXPECT_TRUE(exactResult.converged);
  EXPECT_TRUE(inexactResult.converged);
  const std::vector<double> reference = projectedGaussSeidel(b, 0.49);
  double largest = 0;
  for (double r : reference) largest = std::max(largest, r);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_NEAR(exact[i], reference[i], 1e-6 * largest) << i;
    EXPECT_NEAR(inexact[i], reference[i], 1e-6 * largest) << i;
  }
  EXPECT_LT(inexactResult.products, exactResult.products);
  std::cout << "[bound-constrained CG] n " << n << ": exact phases " << exactResult.products << " products ("
            << exactResult.activeSetSteps << " bound-set steps), inexact " << inexactResult.products << " ("
            << inexactResult.activeSetSteps << ")\n";
}

namespace {
/// Laplacian1D with M = I + Z (Z^T A Z)^-1 Z^T, Z the indicators of `size` consecutive nodes.
struct TwoLevelLaplacian1D : Laplacian1D {
  std::size_t size = 16;
  Eigen::LDLT<Eigen::MatrixXd> coarse;
  void prepare(std::size_t n) {
    const std::size_t m = (n + size - 1) / size;
    Eigen::MatrixXd Ac = Eigen::MatrixXd::Zero(Eigen::Index(m), Eigen::Index(m));
    std::vector<double> e(n), Ae(n);
    for (std::size_t c = 0; c < m; ++c) {
      for (std::size_t i = 0; i < n; ++i) e[i] = i / size == c ? 1.0 : 0.0;
      double unused = 0;
      product(e, Ae, unused);
      for (std::size_t i = 0; i < n; ++i) Ac(Eigen::Index(i / size), Eigen::Index(c)) += Ae[i];
    }
    coarse.compute(Ac);
  }
  void precondition(std::vector<double>& z, const std::vector<char>& bound) const {
    Eigen::VectorXd r = Eigen::VectorXd::Zero(coarse.rows());
    for (std::size_t i = 0; i < z.size(); ++i)
      if (!bound[i]) r[Eigen::Index(i / size)] += z[i];
    const Eigen::VectorXd y = coarse.solve(r);
    for (std::size_t i = 0; i < z.size(); ++i) z[i] = bound[i] ? 0.0 : z[i] + y[Eigen::Index(i / size)];
  }
};
} // namespace

TEST(BoundConstrainedCG, TwoLevelPreconditioningReachesTheSameKktPointInFewerProducts) {
  // A long obstacle problem whose free stretches are hundreds of nodes long: their smooth
  // modes take plain CG about as many products as the stretch has nodes.
  const std::size_t n = 2000;
  std::vector<double> b(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = double(i) / double(n - 1);
    b[i] = 1e-4 * (std::sin(3.0 * M_PI * s) + 0.3 * std::sin(17.0 * M_PI * s)) - 2e-5;
  }
  auto check = [&](const Laplacian1D& A, const std::vector<double>& x) {
    const std::vector<double> exact = gradientOf(A, x, b);
    int bound = 0;
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_GE(x[i], 0.0) << i;
      EXPECT_GE(exact[i], -1e-10) << i;
      EXPECT_LE(x[i] > 0 ? std::abs(exact[i]) : 0.0, 1e-10) << i;
      bound += x[i] == 0.0 ? 1 : 0;
    }
    return bound;
  };
  Laplacian1D plain;
  plain.tolerance = 1e-8;
  plain.maxResidual = 1e-10;
  std::vector<double> x(n, 0.0), g = gradientOf(plain, x, b);
  const BoundConstrainedResult jacobi = solveBoundConstrained(plain, x, g, 100000);
  TwoLevelLaplacian1D twoLevel;
  twoLevel.tolerance = plain.tolerance;
  twoLevel.maxResidual = plain.maxResidual;
  twoLevel.prepare(n);
  std::vector<double> y(n, 0.0), h = gradientOf(twoLevel, y, b);
  const BoundConstrainedResult preconditioned = solveBoundConstrained(twoLevel, y, h, 100000);
  EXPECT_TRUE(jacobi.converged);
  EXPECT_TRUE(preconditioned.converged);
  const int boundPlain = check(plain, x), boundTwoLevel = check(twoLevel, y);
  EXPECT_GT(boundPlain, 100);  // stretches at the bound
  EXPECT_EQ(boundPlain, boundTwoLevel);
  // The KKT conditions above determine the answer (A is positive definite): both agree.
  double largest = 0;
  for (double v : x) largest = std::max(largest, v);
  for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(y[i], x[i], 1e-6 * largest) << i;
  EXPECT_LT(2 * preconditioned.products, jacobi.products);
  std::cout << "[bound-constrained CG] n " << n << ": Jacobi " << jacobi.products << " products, two-level "
            << preconditioned.products << "; " << boundPlain << " at the bound\n";
}
