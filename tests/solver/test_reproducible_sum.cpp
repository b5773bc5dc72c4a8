// Sums whose bits do not depend on the order of the terms (ReproducibleSum.h): the
// property that makes a rigid body's force, and DFSPH's solves, the same on any MPI
// rank count. Terms over 16 decades of both signs, where a plain sum's bits follow
// the order.
#include "libsph/solver/ReactionSums.h"
#include "libsph/solver/ReproducibleSum.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace cascade::test {
namespace {

std::vector<double> wideTerms(std::size_t n, unsigned seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> decade(-8, 8), sign(-1, 1);
  std::vector<double> terms(n);
  for (double& t : terms) t = std::copysign(std::pow(10.0, decade(random)), sign(random));
  return terms;
}

long double exactish(const std::vector<double>& terms) {
  // Sorted by magnitude in long double: a reference within ~1e-19 of the largest term here.
  std::vector<double> sorted = terms;
  std::sort(sorted.begin(), sorted.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
  long double sum = 0;
  for (double t : sorted) sum += t;
  return sum;
}

} // namespace

TEST(ReproducibleSum, TheSameBitsInAnyOrderAndAccurate) {
  const std::vector<double> terms = wideTerms(20000, 7);
  std::vector<double> scratch = terms;
  const double sum = reproducibleSum(scratch, nullptr);
  std::mt19937 random(3);
  int plainDiffers = 0;
  double plainFirst = 0;
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<double> shuffled = terms;
    std::shuffle(shuffled.begin(), shuffled.end(), random);
    double plain = 0;
    for (double t : shuffled) plain += t;
    if (trial == 0) plainFirst = plain;
    plainDiffers += plain != plainFirst;
    EXPECT_EQ(reproducibleSum(shuffled, nullptr), sum) << "trial " << trial;
  }
  EXPECT_GT(plainDiffers, 0) << "terms too easy: a plain sum gives the same bits in every order";
  // Only about 2^-60 of the largest term (1e8) is dropped.
  EXPECT_NEAR(double(exactish(terms)), sum, 1e8 * 1e-17);
  // All zero, and one term that is not a number: a plain sum.
  std::vector<double> zeros(100, 0.0);
  EXPECT_EQ(reproducibleSum(zeros, nullptr), 0.0);
  std::vector<double> bad = {1.0, std::nan(""), 2.0};
  EXPECT_TRUE(std::isnan(reproducibleSum(bad, nullptr)));
}

TEST(ReproducibleSum, ColumnsOfATableHaveEachColumnsOwnBits) {
  // Three columns of very different scales (a force in kN, a moment in N mm, zeros).
  const std::size_t rows = 5000, width = 3;
  const std::vector<double> a = wideTerms(rows, 11), b = wideTerms(rows, 12);
  std::vector<double> table(rows * width);
  for (std::size_t i = 0; i < rows; ++i) {
    table[i * width] = 1e3 * a[i];
    table[i * width + 1] = 1e-3 * b[i];
    table[i * width + 2] = 0;
  }
  double sums[width];
  reproducibleSums(table.data(), rows, width, sums, nullptr);
  for (std::size_t c = 0; c < width; ++c) {
    std::vector<double> column(rows);
    for (std::size_t i = 0; i < rows; ++i) column[i] = c == 0 ? 1e3 * a[i] : c == 1 ? 1e-3 * b[i] : 0;
    EXPECT_EQ(reproducibleSum(column, nullptr), sums[c]) << "column " << c;
  }
}

TEST(ReactionSums, OneProcessAddsTheChunksInOrder) {
  // Two solids, two quantities; entries over three chunks (the last partial).
  const std::size_t entries = 2 * ReactionSums::kChunk + 17;
  ReactionSums reactions(entries, 2, 2, nullptr);
  const std::vector<double> terms = wideTerms(entries, 5);
  std::vector<Vec3d> chunkSums(ReactionSums::chunks(entries), Vec3d::Zero());
  for (std::size_t k = 0; k < entries; ++k) {
    const Vec3d f(terms[k], -terms[k], 0.5 * terms[k]);
    reactions.record(k)[reactions.index(1, k % 2)] += f;  // quantity 1 of solid k % 2
    if (k % 2 == 1) chunkSums[k / ReactionSums::kChunk] += f;
  }
  const std::vector<Vec3d> totals = reactions.totals();
  Vec3d expected = Vec3d::Zero();
  for (const Vec3d& s : chunkSums) expected += s;
  EXPECT_EQ(totals[reactions.index(1, 1)], expected);
  EXPECT_EQ(totals[reactions.index(0, 0)], Vec3d::Zero());
  EXPECT_EQ(totals[reactions.index(0, 1)], Vec3d::Zero());
  EXPECT_NE(totals[reactions.index(1, 0)], Vec3d::Zero());
}

} // namespace cascade::test
