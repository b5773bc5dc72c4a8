/// @file HalfFloat.h
/// @brief IEEE 754 binary16 ("half") conversions, round to nearest even: what the
///        x86 F16C instructions (vcvtps2ph with rounding mode 0, vcvtph2ps) compute,
///        in portable C++ for machines and code paths without them. Hand-rolled: the
///        standard library has no half type before C++23, and Debian 12 packages none
///        that the solver should depend on for two functions.
///
/// DFSPH stores its per-pair kernel gradients as halves (TimeStepDFSPH.h, PairTerm):
/// the constant-density solve streams them twice per operator product, and 10-byte
/// records instead of 16 are most of its memory traffic.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace cascade {

/// The half nearest f (ties to even); beyond the largest half (65504) infinity, NaN
/// stays NaN (quiet), subnormal halves are kept.
inline std::uint16_t halfFromFloat(float f) {
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  const std::uint16_t sign = static_cast<std::uint16_t>((bits >> 16) & 0x8000u);
  const std::uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude >= 0x7f800000u)  // infinity, or NaN (quiet, with the top of its payload)
    return static_cast<std::uint16_t>(sign | 0x7c00u | (magnitude > 0x7f800000u ? 0x0200u | ((magnitude >> 13) & 0x3ffu) : 0u));
  if (magnitude >= 0x477ff000u) return static_cast<std::uint16_t>(sign | 0x7c00u);  // rounds past 65504
  if (magnitude < 0x38800000u) {  // below the smallest normal half (2^-14): subnormal or zero
    if (magnitude < 0x33000000u) return sign;  // at most half the smallest subnormal (2^-25): to zero (even)
    const std::uint32_t exponent = magnitude >> 23;
    const std::uint32_t mantissa = (magnitude & 0x7fffffu) | 0x800000u;
    const std::uint32_t shift = 126u - exponent;  // value = mantissa 2^(exponent - 150); unit 2^-24
    const std::uint32_t kept = mantissa >> shift, rest = mantissa & ((1u << shift) - 1u), halfway = 1u << (shift - 1u);
    const std::uint32_t rounded = kept + ((rest > halfway || (rest == halfway && (kept & 1u))) ? 1u : 0u);
    return static_cast<std::uint16_t>(sign | rounded);
  }
  // Normal: rebias the exponent (127 -> 15), round the 13 dropped mantissa bits to even.
  const std::uint32_t rebased = magnitude - 0x38000000u;
  const std::uint32_t rounded = rebased + 0x0fffu + ((rebased >> 13) & 1u);
  return static_cast<std::uint16_t>(sign | (rounded >> 13));
}

/// The float equal to half h (every half is exactly a float).
inline float floatFromHalf(std::uint16_t h) {
  const std::uint32_t sign = std::uint32_t(h & 0x8000u) << 16;
  const std::uint32_t exponent = (h >> 10) & 0x1fu, mantissa = h & 0x3ffu;
  std::uint32_t bits;
  if (exponent == 0x1fu) {
    bits = sign | 0x7f800000u | (mantissa << 13);  // infinity or NaN
  } else if (exponent != 0) {
    bits = sign | ((exponent + 112u) << 23) | (mantissa << 13);
  } else if (mantissa == 0) {
    bits = sign;
  } else {  // subnormal: normalise
    std::uint32_t m = mantissa;
    std::uint32_t e = 113u;
    while ((m & 0x400u) == 0) {
      m <<= 1;
      --e;
    }
    bits = sign | (e << 23) | ((m & 0x3ffu) << 13);
  }
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

namespace detail {
#if defined(__x86_64__) || defined(__i386__)
/// Eight at a time with F16C (vcvtps2ph, round to nearest even), the rest one by one.
__attribute__((target("avx,f16c"))) inline void halvesFromFloatsF16c(const float* in, std::uint16_t* out, std::size_t n) {
  std::size_t k = 0;
  for (; k + 8 <= n; k += 8)
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + k), _mm256_cvtps_ph(_mm256_loadu_ps(in + k), _MM_FROUND_TO_NEAREST_INT));
  for (; k < n; ++k) out[k] = halfFromFloat(in[k]);
}
#endif
} // namespace detail

/// out[k] = halfFromFloat(in[k]) for k < n: by F16C where the processor has it.
inline void halvesFromFloats(const float* in, std::uint16_t* out, std::size_t n) {
#if defined(__x86_64__) || defined(__i386__)
  static const bool f16c = __builtin_cpu_supports("avx") && __builtin_cpu_supports("f16c");
  if (f16c) {
    detail::halvesFromFloatsF16c(in, out, n);
    return;
  }
#endif
  for (std::size_t k = 0; k < n; ++k) out[k] = halfFromFloat(in[k]);
}

} // namespace cascade
