/// @file BoundConstrainedCG.h
/// @brief Minimises f(x) = 1/2 x^T A x - b^T x subject to x >= 0, for a symmetric
///        positive semi-definite A given only by its product with a vector: the
///        primal-dual active set method (Hintermueller, Ito & Kunisch 2002, "The
///        primal-dual active set strategy as a semismooth Newton method", SIAM J.
///        Optim. 13(3)) with conjugate-gradient solves on the free set.
///
/// Its KKT conditions, x >= 0, g = A x - b >= 0, x_i g_i = 0, are the one-sided
/// pressure problem of a compression-only SPH solve (x the stiffness, -g the
/// predicted compression): pressure only where the fluid would be compressed, and
/// there exactly enough to remove the compression. Each outer step holds the bound
/// set B = {i : g_i > x_i} at x_i = 0 (the multiplier test with c = 1 on the scaled
/// problem) and runs CG on A_FF x_F = b_F for the rest; then B is taken again from
/// the new x and g, until it stops changing and the caller's tolerance holds. CG
/// converges the smooth, whole-domain modes of a deep pressure field in O(sqrt(cond A))
/// products, where relaxed Jacobi sweeps take O(cond A).
///
/// The caller passes the problem Jacobi-scaled (unit diagonal; a variable with a zero
/// row is inert: its gradient stays 0) through a small concept:
///   - `void product(const std::vector<double>& p, std::vector<double>& Ap, double& pAp)`:
///     Ap = A p and pAp = p . Ap, summed in a fixed order;
///   - `double weight(std::size_t i)`, `double tolerance`, `double maxResidual`: the solve
///     stops when sum_i weight(i) |pg_i| <= tolerance and max_i weight(i) |pg_i| <=
///     maxResidual, pg the projected gradient (weight: back to the caller's units).
/// Optionally, a preconditioner (then CG is preconditioned CG, Hestenes & Stiefel's with
/// r . M r in place of r . r):
///   - `void precondition(std::vector<double>& z, const std::vector<char>& bound)`: z holds
///     the free set's residual r (0 on the bound set, bound[i] != 0) and becomes M r, 0 on
///     the bound set, M symmetric positive definite on the free set
///     (DFSPH's two-level coarse correction: CoarseCorrection.h).
/// Every reduction is a fixed-order sum (ParallelSum.h): the same iterates on any
/// number of threads. A problem split over MPI ranks adds, optionally,
///   - `double sumTerms(std::vector<double>& terms)`: the sum of every rank's terms (scratch)
///     (the same bits however the terms are split: ReproducibleSum.h);
///   - `double largest(double local)`: the maximum over the ranks,
/// and every rank then takes the same steps.
#pragma once

#include "libsph/solver/ParallelSum.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <utility>
#include <vector>

namespace cascade {

struct BoundConstrainedResult {
  int products = 0;       ///< products A p taken (the cost)
  int activeSetSteps = 0;  ///< outer steps that changed the bound set
  bool converged = false;
};

/// The projected gradient of the bound x >= 0: g on the free set, min(g, 0) on the bound.
inline double projectedGradient(double x, double g) { return x > 0 ? g : std::min(g, 0.0); }

/// Norms of the error the caller's stop measures: sum and largest of weight(i) |e_i|, and
/// sum of g_i^2 over the same variables (CG's residual norm), in one fixed-order pass.
struct ErrorNorms {
  double sum = 0, largest = 0, squares = 0;
};

/// ErrorNorms of e_i = error(i) (0 for a variable that does not count), with g_i^2 taken
/// where counted(i); update(i) runs first for each i (an update fused into the same pass).
template <typename Problem, typename Error, typename Counted, typename Update>
ErrorNorms errorNorms(const Problem& problem, std::size_t n, Error&& error, Counted&& counted, Update&& update,
                      const std::vector<double>& g) {
  const std::size_t chunks = (n + kSumChunk - 1) / kSumChunk;
  std::vector<ErrorNorms> partial(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    ErrorNorms norms;
    const std::size_t end = std::min(n, (c + 1) * kSumChunk);
    for (std::size_t i = c * kSumChunk; i < end; ++i) {
      update(i);
      const double e = problem.weight(i) * std::abs(error(i));
      norms.sum += e;
      norms.largest = std::max(norms.largest, e);
      if (counted(i)) norms.squares += g[i] * g[i];
    }
    partial[c] = norms;
  });
  ErrorNorms total;
  for (const ErrorNorms& p : partial) {
    total.sum += p.sum;
    total.largest = std::max(total.largest, p.largest);
    total.squares += p.squares;
  }
  return total;
}

namespace detail {
template <typename P, typename = void>
struct Preconditioned : std::false_type {};
template <typename P>
struct Preconditioned<P, std::void_t<decltype(std::declval<P&>().precondition(std::declval<std::vector<double>&>(),
                                                                                std::declval<const std::vector<char>&>()))>>
    : std::true_type {};
template <typename P, typename = void>
struct SplitOverRanks : std::false_type {};
template <typename P>
struct SplitOverRanks<P, std::void_t<decltype(std::declval<P&>().largest(0.0))>> : std::true_type {};
} // namespace detail

template <typename Problem>
bool withinTolerance(const Problem& problem, const ErrorNorms& norms) {
  return norms.sum <= problem.tolerance && norms.largest <= problem.maxResidual;
}

/// Primal-dual active set with CG inner solves from a feasible x (x >= 0) with
/// g = A x - b; x and g are updated in place; at most maxProducts products.
///
/// The inner solves are inexact (Kanzow 2004, "Inexact semismooth Newton methods for
/// large-scale complementarity problems", Optim. Methods Softw. 19(3-4)): a CG phase
/// on a bound set that the next outer step may still change stops once it has cut the
/// free set's error (sum and largest) by phaseReduction, not at the caller's
/// tolerance. An outer step that changes nothing resumes the same CG (its search
/// direction and Krylov history kept), so the last phase is one unbroken CG to the
/// tolerance, as with exact inner solves; the stop test is unchanged. phaseReduction 0
/// gives exact inner solves (every phase to the tolerance). What 0.1 saves in DFSPH's
/// density solve: docs/dfsph-deep-water.md, "What it costs".
constexpr double kPhaseReduction = 0.1;

template <typename Problem>
BoundConstrainedResult solveBoundConstrained(Problem& problem, std::vector<double>& x, std::vector<double>& g,
                                             int maxProducts, double phaseReduction = kPhaseReduction) {
  const std::size_t n = x.size();
  BoundConstrainedResult result;
  std::vector<char> bound(n, 0);
  std::vector<double> p(n), Ap(n), d(n);
  // Sums and norms: in fixed chunks, or over the problem's ranks.
  std::vector<double> terms, squares;
  auto sum = [&](auto&& f) {
    if constexpr (detail::SplitOverRanks<Problem>::value) {
      terms.resize(n);
      forEachIndex(n, [&](std::size_t i) { terms[i] = f(i); });
      return problem.sumTerms(terms);
    } else {
      return deterministicSum(n, f);
    }
  };
  auto normsOf = [&](auto&& error, auto&& counted, auto&& update) {
    if constexpr (detail::SplitOverRanks<Problem>::value) {
      terms.resize(n);
      squares.resize(n);
      forEachIndex(n, [&](std::size_t i) {
        update(i);
        terms[i] = problem.weight(i) * std::abs(error(i));
        squares[i] = counted(i) ? g[i] * g[i] : 0.0;
      });
      ErrorNorms norms;
      const double local = n > 0 ? parallelMaximum(n, [&](std::size_t i) { return terms[i]; }) : 0.0;
      norms.largest = problem.largest(local);  // one collective call on every rank, empty or not
      norms.sum = problem.sumTerms(terms);     // (the sums use the terms as scratch)
      norms.squares = problem.sumTerms(squares);
      return norms;
    } else {
      return errorNorms(problem, n, error, counted, update, g);
    }
  };
  // Moves x by d (g follows: one product).
  auto move = [&](std::vector<double>& step) {
    double unused = 0;
    problem.product(step, Ap, unused);
    ++result.products;
    forEachIndex(n, [&](std::size_t i) {
      x[i] += step[i];
      g[i] += Ap[i];
    });
  };
  auto none = [](std::size_t) {};
  auto always = [](std::size_t) { return true; };
  auto projected = [&](std::size_t i) { return projectedGradient(x[i], g[i]); };
  auto freeGradient = [&](std::size_t i) { return bound[i] ? 0.0 : g[i]; };
  auto isFree = [&](std::size_t i) { return !bound[i]; };
  bool searching = false;  // p is the live CG direction on the current bound set
  ErrorNorms norms;
  // Preconditioned CG (a problem with precondition(z, bound)): z = M r, rz = r . z.
  std::vector<double> z;
  double rz = 0;
  auto precondition = [&]() {
    if constexpr (detail::Preconditioned<Problem>::value) {
      z.resize(n);
      forEachIndex(n, [&](std::size_t i) { z[i] = -freeGradient(i); });
      problem.precondition(z, bound);
      rz = sum([&](std::size_t i) { return bound[i] ? 0.0 : -g[i] * z[i]; });
    }
  };
  while (true) {
    // The bound set of (x, g); its variables go to 0.
    const double changed = sum([&](std::size_t i) {
      const char b = g[i] > x[i] ? 1 : 0;
      const double flip = b != bound[i] ? 1.0 : 0.0;
      bound[i] = b;
      d[i] = b ? -x[i] : 0.0;
      return flip;
    });
    // (the start may already be the answer)
    if (changed == 0 && withinTolerance(problem, normsOf(projected, always, none))) {
      result.converged = true;
      break;
    }
    if (result.products >= maxProducts) break;
    if (changed > 0) {
      if (sum([&](std::size_t i) { return d[i] != 0 ? 1.0 : 0.0; }) > 0) {
        move(d);
        ++result.activeSetSteps;
      }
      searching = false;
    }
    // CG on the free set (residual -g_F); x may go negative on the way (the next bound
    // set takes those). A new bound set starts a new CG; an unchanged one resumes it.
    if (!searching) {
      norms = normsOf(freeGradient, isFree, none);
      if constexpr (detail::Preconditioned<Problem>::value) {
        precondition();
        forEachIndex(n, [&](std::size_t i) { p[i] = z[i]; });
      } else {
        forEachIndex(n, [&](std::size_t i) { p[i] = -freeGradient(i); });
      }
      searching = true;
    }
    const double phaseSum = std::max(problem.tolerance, phaseReduction * norms.sum);
    const double phaseLargest = std::max(problem.maxResidual, phaseReduction * norms.largest);
    while (result.products < maxProducts && norms.squares > 0 &&
           !(norms.sum <= phaseSum && norms.largest <= phaseLargest)) {
      double pAp = 0;
      problem.product(p, Ap, pAp);
      ++result.products;
      if (!(pAp > 0)) {  // p in A's null space: nothing left to reduce along it
        searching = false;
        break;
      }
      // CG: r . r for the step and the next direction; PCG: r . M r.
      const double last = detail::Preconditioned<Problem>::value ? rz : norms.squares;
      if (!(last > 0)) {  // M r = 0: nothing left to reduce in M's norm
        searching = false;
        break;
      }
      const double alpha = last / pAp;
      norms = normsOf(freeGradient, isFree, [&](std::size_t i) {
        x[i] += alpha * p[i];
        g[i] += alpha * Ap[i];
      });
      if constexpr (detail::Preconditioned<Problem>::value) {
        precondition();
        const double beta = rz / last;
        forEachIndex(n, [&](std::size_t i) { p[i] = z[i] + beta * p[i]; });
      } else {
        const double beta = norms.squares / last;
        forEachIndex(n, [&](std::size_t i) { p[i] = -freeGradient(i) + beta * p[i]; });
      }
    }
    if (norms.squares == 0 && changed == 0) break;  // nothing left to move, and nothing flips
  }
  // A feasible answer: what the cap left negative goes to the bound.
  forEachIndex(n, [&](std::size_t i) { d[i] = x[i] < 0 ? -x[i] : 0.0; });
  if (sum([&](std::size_t i) { return d[i]; }) > 0) move(d);
  return result;
}

} // namespace cascade
