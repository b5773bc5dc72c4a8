// HalfFloat.h: IEEE binary16 conversions, round to nearest even, checked against the
// definition (the nearest half by exact distances, ties to the even one) on every half
// and on floats across the whole range, and against the F16C instructions where the
// CPU has them (the DFSPH pair loops use those; both paths must store the same bits).
#include "libsph/solver/HalfFloat.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define CASCADE_TEST_F16C 1
__attribute__((target("f16c"))) static std::uint16_t hardwareHalf(float f) {
  return static_cast<std::uint16_t>(_mm_extract_epi16(_mm_cvtps_ph(_mm_set_ss(f), 0), 0));
}
__attribute__((target("f16c"))) static float hardwareFloat(std::uint16_t h) {
  return _mm_cvtss_f32(_mm_cvtph_ps(_mm_cvtsi32_si128(h)));
}
static bool haveF16c() { return __builtin_cpu_supports("f16c"); }
#endif

using namespace cascade;

namespace {
float bitsToFloat(std::uint32_t bits) {
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}
bool isNanHalf(std::uint16_t h) { return (h & 0x7c00u) == 0x7c00u && (h & 0x3ffu) != 0; }

/// The nearest half to f by definition: among the halves around f (same sign), the one at
/// the smallest exact distance, ties to an even mantissa; past 65520 infinity.
std::uint16_t nearestHalf(float f) {
  const std::uint16_t sign = std::signbit(f) ? 0x8000u : 0u;
  const double a = std::fabs(double(f));
  if (a >= 65520.0) return std::uint16_t(sign | 0x7c00u);
  std::uint16_t best = 0;
  double bestDistance = INFINITY;
  // Halves are monotonic in their bits: search the bit pattern below and above a.
  std::uint16_t lo = 0, hi = 0x7bffu;
  while (hi - lo > 1) {
    const std::uint16_t mid = std::uint16_t((lo + hi) / 2);
    if (double(floatFromHalf(mid)) <= a) lo = mid; else hi = mid;
  }
  for (std::uint16_t c : {lo, hi}) {
    const double d = std::fabs(double(floatFromHalf(c)) - a);
    if (d < bestDistance || (d == bestDistance && (c & 1u) == 0)) {
      best = c;
      bestDistance = d;
    }
  }
  return std::uint16_t(sign | best);
}
} // namespace

TEST(HalfFloat, EveryHalfRoundTripsThroughFloat) {
  for (std::uint32_t h = 0; h <= 0xffffu; ++h) {
    const float f = floatFromHalf(std::uint16_t(h));
    if (isNanHalf(std::uint16_t(h))) {
      EXPECT_TRUE(std::isnan(f)) << h;
      EXPECT_TRUE(isNanHalf(halfFromFloat(f))) << h;
      continue;
    }
    ASSERT_EQ(halfFromFloat(f), h) << "half " << h << " read as " << f;
  }
  EXPECT_EQ(floatFromHalf(0x3c00u), 1.0f);
  EXPECT_EQ(floatFromHalf(0x7bffu), 65504.0f);
  EXPECT_EQ(floatFromHalf(0x0001u), std::ldexp(1.0f, -24));  // the smallest subnormal
  EXPECT_EQ(floatFromHalf(0x0400u), std::ldexp(1.0f, -14));  // the smallest normal
}

TEST(HalfFloat, FloatsRoundToTheNearestHalfTiesToEven) {
  // Ties, exactly: 1 + 2^-11 lies halfway between 1 and 1 + 2^-10 (to 1, even), and
  // 1 + 3 2^-11 between 1 + 2^-10 and 1 + 2^-9 (to the even 1 + 2^-9).
  EXPECT_EQ(halfFromFloat(1.0f + std::ldexp(1.0f, -11)), 0x3c00u);
  EXPECT_EQ(halfFromFloat(1.0f + 3 * std::ldexp(1.0f, -11)), 0x3c02u);
  EXPECT_EQ(halfFromFloat(65519.0f), 0x7bffu);
  EXPECT_EQ(halfFromFloat(65520.0f), 0x7c00u);
  EXPECT_EQ(halfFromFloat(std::ldexp(1.0f, -25)), 0x0000u);          // halfway to the smallest subnormal
  EXPECT_EQ(halfFromFloat(std::ldexp(1.5f, -25)), 0x0001u);
  EXPECT_EQ(halfFromFloat(-std::ldexp(1.0f, -14) * 0.99999f), 0x8400u);  // rounds up into the normals
  // Every float exponent a half can hold, and beyond, with random mantissas and both signs.
  std::mt19937 random(20261128);
  std::uniform_int_distribution<std::uint32_t> mantissa(0, 0x7fffffu), exponent(96, 145), sign(0, 1);
  for (int k = 0; k < 400000; ++k) {
    const float f = bitsToFloat((sign(random) << 31) | (exponent(random) << 23) | mantissa(random));
    ASSERT_EQ(halfFromFloat(f), nearestHalf(f)) << f;
  }
  // Exactly the midpoints between neighbouring halves, and one float either side of them.
  for (std::uint32_t h = 0; h < 0x7bffu; h += 7) {
    const double mid = 0.5 * (double(floatFromHalf(std::uint16_t(h))) + double(floatFromHalf(std::uint16_t(h + 1))));
    const float m = float(mid);
    for (float f : {m, std::nextafter(m, 0.0f), std::nextafter(m, 1e9f)}) ASSERT_EQ(halfFromFloat(f), nearestHalf(f)) << f;
  }
  EXPECT_EQ(halfFromFloat(INFINITY), 0x7c00u);
  EXPECT_EQ(halfFromFloat(-INFINITY), 0xfc00u);
  EXPECT_TRUE(isNanHalf(halfFromFloat(NAN)));
}

TEST(HalfFloat, RoundingIsOddSymmetricSoPairGradientsStayAntisymmetric) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> value(-3000.0f, 3000.0f);
  for (int k = 0; k < 100000; ++k) {
    const float f = value(random);
    EXPECT_EQ(halfFromFloat(-f), std::uint16_t(halfFromFloat(f) ^ 0x8000u));
  }
}

#ifdef CASCADE_TEST_F16C
TEST(HalfFloat, MatchesTheF16cInstructions) {
  if (!haveF16c()) GTEST_SKIP() << "this CPU has no F16C";
  for (std::uint32_t h = 0; h <= 0xffffu; ++h) {
    if (isNanHalf(std::uint16_t(h))) continue;
    ASSERT_EQ(floatFromHalf(std::uint16_t(h)), hardwareFloat(std::uint16_t(h))) << h;
  }
  std::mt19937 random(11);
  std::uniform_int_distribution<std::uint32_t> bits;
  for (int k = 0; k < 2000000; ++k) {
    const float f = bitsToFloat(bits(random));
    if (std::isnan(f)) continue;
    ASSERT_EQ(halfFromFloat(f), hardwareHalf(f)) << f;
  }
}
#endif
