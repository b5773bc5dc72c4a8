#include "libsph/solver/TimeStepWCSPH.h"

#include "libsph/Kernels.h"
#include "libsph/boundary/BoundaryParticles.h"
#include "libsph/search/CompressTable.h"
#include "libsph/solver/DomainPartition.h"
#include "libsph/solver/EquationOfState.h"
#include "libsph/solver/ListOrder.h"
#include "libsph/solver/ReactionSums.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#if (defined(__x86_64__) || defined(__i386__)) && !defined(CASCADE_DOUBLE) && \
    (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define CASCADE_WCSPH_AVX2 1
#endif

namespace cascade {

namespace {

using Clock = std::chrono::steady_clock;
double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// Density (/ rho_0) from which a particle belongs to a water body for the
/// surface-layer pressure: the top layer of a resting pool has 0.88 (Wendland C2,
/// h = 2 spacings), isolated spray much less.
constexpr double kSurfaceLayerDensity = 0.8;

/// The kernel pair of the density and the pressure gradient (SolverSettings::kernels):
/// W(r) = valueCoeff * valueShape(r^2), grad W(r) = gradientCoeff * gradientShape(|r|) * r_vec.
struct KernelConstants {
  KernelPair pair = KernelPair::Mueller2003;
  Real supportRadius = 0, supportRadius2 = 0, inverseSupport = 0;
  Real valueCoeff = 0, gradientCoeff = 0;

  KernelConstants() = default;
  KernelConstants(KernelPair kernels, Real h)
      : pair(kernels), supportRadius(h), supportRadius2(h * h), inverseSupport(Real(1) / h) {
    switch (kernels) {
      case KernelPair::Mueller2003:
        valueCoeff = KernelPoly6(h).valueCoeff;      // SEED (7)
        gradientCoeff = KernelSpiky(h).gradientCoeff;  // SEED (8)
        break;
      case KernelPair::CubicSpline:
        valueCoeff = KernelCubicSpline(h).valueCoeff;
        gradientCoeff = KernelCubicSpline(h).gradientCoeff;
        break;
      case KernelPair::Automatic:  // chosen in Simulation::start
      case KernelPair::WendlandC2:
        valueCoeff = KernelWendlandC2(h).valueCoeff;
        gradientCoeff = KernelWendlandC2(h).gradientCoeff;
        break;
    }
  }
};

/// W / valueCoeff for r^2 < h^2 (the caller checks the support).
template <KernelPair K>
inline Real valueShape(const KernelConstants& k, Real r2) {
  if constexpr (K == KernelPair::Mueller2003) {
    const Real d = k.supportRadius2 - r2;  // poly6: (h^2 - r^2)^3
    return d * d * d;
  } else if constexpr (K == KernelPair::CubicSpline) {
    const Real q = std::sqrt(r2) * k.inverseSupport;
    if (q <= Real(0.5)) return Real(6) * q * q * (q - Real(1)) + Real(1);
    const Real d = Real(1) - q;
    return Real(2) * d * d * d;
  } else {
    const Real q = std::sqrt(r2) * k.inverseSupport;
    const Real d = Real(1) - q, d2 = d * d;  // Wendland C2: (1 - q)^4 (1 + 4 q)
    return d2 * d2 * (Real(1) + Real(4) * q);
  }
}

/// grad W / (gradientCoeff r_vec) for 0 < |r| < h.
template <KernelPair K>
inline Real gradientShape(const KernelConstants& k, Real len) {
  if constexpr (K == KernelPair::Mueller2003) {
    const Real d = k.supportRadius - len;  // spiky, SEED (8): (h - r)^2 / r
    return d * d / len;
  } else if constexpr (K == KernelPair::CubicSpline) {
    const Real q = len * k.inverseSupport;
    if (q <= Real(0.5)) return (Real(3) * q - Real(2)) * k.inverseSupport;  // q (3q - 2) / r
    const Real d = Real(1) - q;
    return -d * d / len;
  } else {
    const Real d = Real(1) - len * k.inverseSupport;  // Wendland C2: (1 - q)^3
    return d * d * d;
  }
}

/// The kernel's lattice sums on the cubic lattice of `spacing` around a lattice
/// point: sum_j W (self included) and -(1/3) sum_j (x_i - x_j) . grad W.
struct LatticeSums {
  double value = 0, gradient = 0;
};
template <KernelPair K>
LatticeSums latticeSums(const KernelConstants& k, Real spacing) {
  const int reach = static_cast<int>(std::ceil(k.supportRadius / spacing));
  LatticeSums sums;
  for (int z = -reach; z <= reach; ++z)
    for (int y = -reach; y <= reach; ++y)
      for (int x = -reach; x <= reach; ++x) {
        const Real r2 = spacing * spacing * Real(x * x + y * y + z * z);
        if (r2 >= k.supportRadius2) continue;
        sums.value += double(k.valueCoeff * valueShape<K>(k, r2));
        if (r2 > 0) sums.gradient -= double(r2 * k.gradientCoeff * gradientShape<K>(k, std::sqrt(r2))) / 3.0;
      }
  return sums;
}

/// The constants of the fluid pair loop (SEED (5), (6), Monaghan 1992).
struct ForceConstants {
  KernelConstants kernel;
  Real pressureCoeff;    // -m (1 or 1/2) / C
  Real artificialCoeff;  // 2 m alpha h c
  Real epsilon2;         // 0.01 h^2
  bool hamiltonian;      // p_i / rho_i^2 + p_j / rho_j^2 instead of (p_i + p_j) / (rho_i rho_j)
  bool artificial, viscous;
  bool allPairs;         // artificial viscosity also for receding pairs
};

/// The particle whose neighbours are summed (or a mirror pre-image of it).
struct ForceQuery {
  Real x, y, z, vx, vy, vz, pressure, density, inverseDensity;
};

/// sum_j f_ij grad W_ij (pressure and artificial viscosity, SEED (5)) and
/// sum_j (h - r_ij) / rho_j v_ij (the viscosity sum of SEED (6)).
struct ForceSums {
  Vec3r pressure = Vec3r::Zero();
  Vec3r viscous = Vec3r::Zero();
};

/// One pair, shared by every path: adds j's terms to the sums.
template <KernelPair K>
inline void addPairTerms(const ForceConstants& k, const ForceQuery& q, const wcsph::PairInput& pj,
                         ForceSums& sums) {
  const Vec3r r(q.x - pj.x, q.y - pj.y, q.z - pj.z);
  const Real r2 = r.squaredNorm();
  if (r2 >= k.kernel.supportRadius2 || r2 <= Real(0)) return;
  const Real len = std::sqrt(r2);
  const Real invRhoj = Real(1) / pj.density;
  // SEED (5) / rho_i: -m (p_i + p_j) / (rho_i rho_j) grad W, or Monaghan 1992:
  // -m (p_i / rho_i^2 + p_j / rho_j^2) grad W
  Real scalar = k.hamiltonian ? k.pressureCoeff * (q.pressure * q.inverseDensity * q.inverseDensity +
                                                   pj.pressure * invRhoj * invRhoj)
                              : k.pressureCoeff * (q.pressure + pj.pressure) * q.inverseDensity * invRhoj;
  const Vec3r relativeVelocity(q.vx - pj.vx, q.vy - pj.vy, q.vz - pj.vz);
  const Real vr = relativeVelocity.dot(r);
  if (k.artificial && (vr < 0 || k.allPairs))  // Monaghan 1992
    scalar += k.artificialCoeff * vr / ((q.density + pj.density) * (r2 + k.epsilon2));
  sums.pressure += (scalar * k.kernel.gradientCoeff * gradientShape<K>(k.kernel, len)) * r;
  if (k.viscous) sums.viscous += ((k.kernel.supportRadius - len) * invRhoj) * relativeVelocity;
}

void addPairTerms(const ForceConstants& k, const ForceQuery& q, const wcsph::PairInput& pj, ForceSums& sums) {
  switch (k.kernel.pair) {
    case KernelPair::Mueller2003: return addPairTerms<KernelPair::Mueller2003>(k, q, pj, sums);
    case KernelPair::CubicSpline: return addPairTerms<KernelPair::CubicSpline>(k, q, pj, sums);
    case KernelPair::Automatic:  // chosen in Simulation::start
    case KernelPair::WendlandC2: return addPairTerms<KernelPair::WendlandC2>(k, q, pj, sums);
  }
}

/// Sum over neighbours[0 .. count) (scalar).
template <KernelPair K>
ForceSums forceSumsScalar(const ForceConstants& k, const wcsph::PairInput* particles, const ForceQuery& q,
                          const std::uint32_t* neighbors, std::uint32_t count) {
  ForceSums sums;
  for (std::uint32_t n = 0; n < count; ++n) addPairTerms<K>(k, q, particles[neighbors[n]], sums);
  return sums;
}

/// sum_j W_ij / valueCoeff over neighbours within h (the sum of SEED (4), scalar).
template <KernelPair K>
Real kernelSumScalar(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q,
                     const std::uint32_t* neighbors, std::uint32_t count) {
  Real sum = 0;
  for (std::uint32_t n = 0; n < count; ++n) {
    const wcsph::PairInput& pj = particles[neighbors[n]];
    const Real r2 = squaredDistance(q, Vec3r(pj.x, pj.y, pj.z));
    if (r2 < k.supportRadius2) sum += valueShape<K>(k, r2);
  }
  return sum;
}

/// Mirror images summed in the fluid density's pass (type II, SEED section 2.2): up
/// to kFusedImages pre-images y_m of a layer particle, each map's neighbours within
/// sqrt(keep2) of y_m (keep2 >= h^2) written in list order to kept[m].
constexpr int kFusedImages = 8;
struct FusedImages {
  int count = 0;
  Vec3r preImage[kFusedImages];
  std::uint32_t* kept[kFusedImages];
  std::uint32_t keptCount[kFusedImages];
  Real sum[kFusedImages];  ///< of W / valueCoeff around y_m over neighbours within h
};

/// sum_j W / valueCoeff over neighbours within h of q (if withFluid; else 0), and in the
/// same pass each image's sum and kept neighbours (FusedImages), scalar.
template <KernelPair K>
Real kernelSumImagesScalar(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q,
                           bool withFluid, const std::uint32_t* neighbors, std::uint32_t count, Real keep2,
                           FusedImages& images) {
  Real sum = 0;
  for (int m = 0; m < images.count; ++m) images.sum[m] = 0, images.keptCount[m] = 0;
  for (std::uint32_t n = 0; n < count; ++n) {
    const wcsph::PairInput& pj = particles[neighbors[n]];
    const Vec3r xj(pj.x, pj.y, pj.z);
    if (withFluid) {
      const Real r2 = squaredDistance(q, xj);
      if (r2 < k.supportRadius2) sum += valueShape<K>(k, r2);
    }
    for (int m = 0; m < images.count; ++m) {
      const Real r2 = squaredDistance(images.preImage[m], xj);
      if (r2 < k.supportRadius2) images.sum[m] += valueShape<K>(k, r2);
      images.kept[m][images.keptCount[m]] = neighbors[n];  // kept if within: no branch to mispredict
      images.keptCount[m] += r2 < keep2 ? 1u : 0u;
    }
  }
  return sum;
}

#ifdef CASCADE_WCSPH_AVX2
#define CASCADE_WCSPH_TARGET __attribute__((target("avx2")))
#define CASCADE_WCSPH_INLINE __attribute__((target("avx2"), always_inline)) inline
/// The force loop compiled again with AVX-512VL's encodings: 32 vector registers
/// instead of 16, nothing else (the same instructions' results). (The density
/// loops spill nothing, or keep their image sums in memory either way: no gain.)
#define CASCADE_WCSPH_AVX512_REGISTERS __attribute__((target("avx2,avx512f,avx512vl")))

CASCADE_WCSPH_TARGET inline float horizontalSum(__m256 v) {
  const __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  const __m128 t = _mm_add_ps(s, _mm_movehl_ps(s, s));
  return _mm_cvtss_f32(_mm_add_ss(t, _mm_shuffle_ps(t, t, 1)));
}

/// All bits set in lanes [0, lanes).
CASCADE_WCSPH_TARGET inline __m256 laneMask(std::uint32_t lanes) {
  return _mm256_castsi256_ps(
      _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(lanes)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
}

/// The records of eight neighbours (unused lanes repeat the first), transposed:
/// field[f] holds field f of the eight.
CASCADE_WCSPH_TARGET inline void loadRecords(const wcsph::PairInput* particles, const std::uint32_t* neighbors,
                                            std::uint32_t lanes, __m256 field[8]) {
  __m256 row[8];
  if (lanes == 8)
    for (std::uint32_t l = 0; l < 8; ++l) row[l] = _mm256_load_ps(&particles[neighbors[l]].x);
  else
    for (std::uint32_t l = 0; l < 8; ++l) row[l] = _mm256_load_ps(&particles[neighbors[l < lanes ? l : 0]].x);
  __m256 t[8], u[8];
  for (int p = 0; p < 4; ++p) {
    t[2 * p] = _mm256_unpacklo_ps(row[2 * p], row[2 * p + 1]);
    t[2 * p + 1] = _mm256_unpackhi_ps(row[2 * p], row[2 * p + 1]);
  }
  for (int h = 0; h < 2; ++h) {
    u[4 * h + 0] = _mm256_shuffle_ps(t[4 * h + 0], t[4 * h + 2], 0x44);
    u[4 * h + 1] = _mm256_shuffle_ps(t[4 * h + 0], t[4 * h + 2], 0xEE);
    u[4 * h + 2] = _mm256_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0x44);
    u[4 * h + 3] = _mm256_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0xEE);
  }
  for (int f = 0; f < 4; ++f) {
    field[f] = _mm256_permute2f128_ps(u[f], u[4 + f], 0x20);
    field[4 + f] = _mm256_permute2f128_ps(u[f], u[4 + f], 0x31);
  }
}

/// Positions of eight neighbours (unused lanes repeat the first).
CASCADE_WCSPH_TARGET inline void loadPositions(const wcsph::PairInput* particles, const std::uint32_t* neighbors,
                                              std::uint32_t lanes, __m256& x, __m256& y, __m256& z) {
  __m256 row[4];
  if (lanes == 8)
    for (std::uint32_t l = 0; l < 4; ++l)
      row[l] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(&particles[neighbors[l]].x)),
                                    _mm_load_ps(&particles[neighbors[l + 4]].x), 1);
  else
    for (std::uint32_t l = 0; l < 4; ++l) {
      const __m128 low = _mm_load_ps(&particles[neighbors[l < lanes ? l : 0]].x);
      const __m128 high = _mm_load_ps(&particles[neighbors[l + 4 < lanes ? l + 4 : 0]].x);
      row[l] = _mm256_insertf128_ps(_mm256_castps128_ps256(low), high, 1);
    }
  const __m256 t0 = _mm256_unpacklo_ps(row[0], row[1]), t1 = _mm256_unpackhi_ps(row[0], row[1]);
  const __m256 t2 = _mm256_unpacklo_ps(row[2], row[3]), t3 = _mm256_unpackhi_ps(row[2], row[3]);
  x = _mm256_shuffle_ps(t0, t2, 0x44);
  y = _mm256_shuffle_ps(t0, t2, 0xEE);
  z = _mm256_shuffle_ps(t1, t3, 0x44);
}

/// gradientShape for eight distances (lanes outside (0, h) give anything; the caller masks them).
template <KernelPair K>
CASCADE_WCSPH_TARGET inline __m256 gradientShapeAvx2(const KernelConstants& k, __m256 len) {
  const __m256 one = _mm256_set1_ps(1.0f);
  if constexpr (K == KernelPair::Mueller2003) {
    const __m256 d = _mm256_sub_ps(_mm256_set1_ps(k.supportRadius), len);
    return _mm256_div_ps(_mm256_mul_ps(d, d), len);
  } else if constexpr (K == KernelPair::CubicSpline) {
    const __m256 invH = _mm256_set1_ps(k.inverseSupport);
    const __m256 q = _mm256_mul_ps(len, invH);
    const __m256 inner = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(_mm256_set1_ps(3.0f), q), _mm256_set1_ps(2.0f)), invH);
    const __m256 d = _mm256_sub_ps(one, q);
    const __m256 outer = _mm256_div_ps(_mm256_sub_ps(_mm256_setzero_ps(), _mm256_mul_ps(d, d)), len);
    return _mm256_blendv_ps(outer, inner, _mm256_cmp_ps(q, _mm256_set1_ps(0.5f), _CMP_LE_OQ));
  } else {
    const __m256 d = _mm256_sub_ps(one, _mm256_mul_ps(len, _mm256_set1_ps(k.inverseSupport)));
    return _mm256_mul_ps(_mm256_mul_ps(d, d), d);
  }
}

/// valueShape for eight squared distances (lanes outside the support give anything).
template <KernelPair K>
CASCADE_WCSPH_TARGET inline __m256 valueShapeAvx2(const KernelConstants& k, __m256 r2) {
  const __m256 one = _mm256_set1_ps(1.0f);
  if constexpr (K == KernelPair::Mueller2003) {
    const __m256 d = _mm256_sub_ps(_mm256_set1_ps(k.supportRadius2), r2);
    return _mm256_mul_ps(_mm256_mul_ps(d, d), d);
  } else if constexpr (K == KernelPair::CubicSpline) {
    const __m256 q = _mm256_mul_ps(_mm256_sqrt_ps(r2), _mm256_set1_ps(k.inverseSupport));
    const __m256 inner = _mm256_add_ps(
        _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(6.0f), _mm256_mul_ps(q, q)), _mm256_sub_ps(q, one)), one);
    const __m256 d = _mm256_sub_ps(one, q);
    const __m256 outer = _mm256_mul_ps(_mm256_set1_ps(2.0f), _mm256_mul_ps(_mm256_mul_ps(d, d), d));
    return _mm256_blendv_ps(outer, inner, _mm256_cmp_ps(q, _mm256_set1_ps(0.5f), _CMP_LE_OQ));
  } else {
    const __m256 q = _mm256_mul_ps(_mm256_sqrt_ps(r2), _mm256_set1_ps(k.inverseSupport));
    const __m256 d = _mm256_sub_ps(one, q);
    const __m256 d2 = _mm256_mul_ps(d, d);
    return _mm256_mul_ps(_mm256_mul_ps(d2, d2), _mm256_add_ps(one, _mm256_mul_ps(_mm256_set1_ps(4.0f), q)));
  }
}

/// forceSumsScalar, eight neighbours at a time (the same terms; sums in another order).
/// Inlined into forceSumsAvx2 and forceSumsAvx512Registers (the same operations in the
/// same order, so the same bits; the second compiled with AVX-512VL's 32 registers:
/// 17 stack references in the loop instead of 59).
template <KernelPair K>
CASCADE_WCSPH_INLINE ForceSums forceSumsBody(const ForceConstants& k, const wcsph::PairInput* particles,
                                             const ForceQuery& q, const std::uint32_t* neighbors,
                                             std::uint32_t count) {
  const __m256 qx = _mm256_set1_ps(q.x), qy = _mm256_set1_ps(q.y), qz = _mm256_set1_ps(q.z);
  const __m256 qvx = _mm256_set1_ps(q.vx), qvy = _mm256_set1_ps(q.vy), qvz = _mm256_set1_ps(q.vz);
  const __m256 qPressure = _mm256_set1_ps(q.pressure), qDensity = _mm256_set1_ps(q.density);
  const __m256 qInverseDensity = _mm256_set1_ps(q.inverseDensity);
  const __m256 qPressureTerm = _mm256_set1_ps(q.pressure * q.inverseDensity * q.inverseDensity);
  const __m256 h = _mm256_set1_ps(k.kernel.supportRadius), h2 = _mm256_set1_ps(k.kernel.supportRadius2);
  const __m256 pressureCoeff = _mm256_set1_ps(k.pressureCoeff);
  const __m256 gradientCoeff = _mm256_set1_ps(k.kernel.gradientCoeff);
  const __m256 artificialCoeff = _mm256_set1_ps(k.artificialCoeff), epsilon2 = _mm256_set1_ps(k.epsilon2);
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  __m256 ax = zero, ay = zero, az = zero, vx = zero, vy = zero, vz = zero;
  for (std::uint32_t first = 0; first < count; first += 8) {
    const std::uint32_t lanes = std::min<std::uint32_t>(8, count - first);
    __m256 f[8];  // x, y, z, pressure, vx, vy, vz, density
    loadRecords(particles, neighbors + first, lanes, f);
    const __m256 rx = _mm256_sub_ps(qx, f[0]), ry = _mm256_sub_ps(qy, f[1]), rz = _mm256_sub_ps(qz, f[2]);
    const __m256 r2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(rx, rx), _mm256_mul_ps(ry, ry)), _mm256_mul_ps(rz, rz));
    __m256 valid = _mm256_and_ps(_mm256_cmp_ps(r2, h2, _CMP_LT_OQ), _mm256_cmp_ps(r2, zero, _CMP_GT_OQ));
    if (lanes < 8) valid = _mm256_and_ps(valid, laneMask(lanes));
    // Mirror images are mostly farther than h: skip blocks with none within.
    if (_mm256_testz_ps(valid, valid)) continue;
    const __m256 len = _mm256_sqrt_ps(r2);
    const __m256 invRhoj = _mm256_div_ps(one, f[7]);
    __m256 scalar =
        k.hamiltonian
            ? _mm256_mul_ps(pressureCoeff,
                            _mm256_add_ps(qPressureTerm, _mm256_mul_ps(_mm256_mul_ps(f[3], invRhoj), invRhoj)))
            : _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(pressureCoeff, _mm256_add_ps(qPressure, f[3])),
                                          qInverseDensity),
                            invRhoj);
    const __m256 rvx = _mm256_sub_ps(qvx, f[4]), rvy = _mm256_sub_ps(qvy, f[5]), rvz = _mm256_sub_ps(qvz, f[6]);
    if (k.artificial) {
      const __m256 vr =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(rvx, rx), _mm256_mul_ps(rvy, ry)), _mm256_mul_ps(rvz, rz));
      const __m256 term = _mm256_div_ps(_mm256_mul_ps(artificialCoeff, vr),
                                        _mm256_mul_ps(_mm256_add_ps(qDensity, f[7]), _mm256_add_ps(r2, epsilon2)));
      scalar = _mm256_add_ps(scalar, k.allPairs ? term : _mm256_and_ps(term, _mm256_cmp_ps(vr, zero, _CMP_LT_OQ)));
    }
    const __m256 factor = _mm256_and_ps(
        _mm256_mul_ps(_mm256_mul_ps(scalar, gradientCoeff), gradientShapeAvx2<K>(k.kernel, len)), valid);
    ax = _mm256_add_ps(ax, _mm256_mul_ps(factor, rx));
    ay = _mm256_add_ps(ay, _mm256_mul_ps(factor, ry));
    az = _mm256_add_ps(az, _mm256_mul_ps(factor, rz));
    if (k.viscous) {
      const __m256 weight = _mm256_and_ps(_mm256_mul_ps(_mm256_sub_ps(h, len), invRhoj), valid);
      vx = _mm256_add_ps(vx, _mm256_mul_ps(weight, rvx));
      vy = _mm256_add_ps(vy, _mm256_mul_ps(weight, rvy));
      vz = _mm256_add_ps(vz, _mm256_mul_ps(weight, rvz));
    }
  }
  ForceSums sums;
  sums.pressure = Vec3r(horizontalSum(ax), horizontalSum(ay), horizontalSum(az));
  if (k.viscous) sums.viscous = Vec3r(horizontalSum(vx), horizontalSum(vy), horizontalSum(vz));
  return sums;
}

/// kernelSumScalar, eight neighbours at a time.
template <KernelPair K>
CASCADE_WCSPH_TARGET Real kernelSumAvx2(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q,
                                        const std::uint32_t* neighbors, std::uint32_t count) {
  const __m256 qx = _mm256_set1_ps(q.x()), qy = _mm256_set1_ps(q.y()), qz = _mm256_set1_ps(q.z());
  const __m256 h2 = _mm256_set1_ps(k.supportRadius2);
  __m256 sum = _mm256_setzero_ps();
  for (std::uint32_t first = 0; first < count; first += 8) {
    const std::uint32_t lanes = std::min<std::uint32_t>(8, count - first);
    __m256 x, y, z;
    loadPositions(particles, neighbors + first, lanes, x, y, z);
    const __m256 dx = _mm256_sub_ps(qx, x), dy = _mm256_sub_ps(qy, y), dz = _mm256_sub_ps(qz, z);
    const __m256 r2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    __m256 within = _mm256_cmp_ps(r2, h2, _CMP_LT_OQ);
    if (lanes < 8) within = _mm256_and_ps(within, laneMask(lanes));
    sum = _mm256_add_ps(sum, _mm256_and_ps(valueShapeAvx2<K>(k, r2), within));
  }
  return horizontalSum(sum);
}

template <KernelPair K>
CASCADE_WCSPH_TARGET ForceSums forceSumsAvx2(const ForceConstants& k, const wcsph::PairInput* particles,
                                             const ForceQuery& q, const std::uint32_t* neighbors,
                                             std::uint32_t count) {
  return forceSumsBody<K>(k, particles, q, neighbors, count);
}
template <KernelPair K>
CASCADE_WCSPH_AVX512_REGISTERS ForceSums forceSumsAvx512Registers(const ForceConstants& k,
                                                                  const wcsph::PairInput* particles,
                                                                  const ForceQuery& q,
                                                                  const std::uint32_t* neighbors,
                                                                  std::uint32_t count) {
  return forceSumsBody<K>(k, particles, q, neighbors, count);
}

/// kernelSumImagesScalar, eight neighbours at a time: one load of the neighbours'
/// positions for the fluid sum and every image's (each sum as kernelSumAvx2 makes it).
template <KernelPair K>
CASCADE_WCSPH_TARGET Real kernelSumImagesAvx2(const KernelConstants& k, const wcsph::PairInput* particles,
                                              const Vec3r& q, bool withFluid, const std::uint32_t* neighbors,
                                              std::uint32_t count, Real keep2, FusedImages& images) {
  const __m256 qx = _mm256_set1_ps(q.x()), qy = _mm256_set1_ps(q.y()), qz = _mm256_set1_ps(q.z());
  const __m256 h2 = _mm256_set1_ps(k.supportRadius2), keepRadius2 = _mm256_set1_ps(keep2);
  const auto& compress = search::compressTable().lanes;
  __m256 sum = _mm256_setzero_ps();
  __m256 imageSum[kFusedImages];
  std::uint32_t kept[kFusedImages];
  for (int m = 0; m < images.count; ++m) imageSum[m] = _mm256_setzero_ps(), kept[m] = 0;
  for (std::uint32_t first = 0; first < count; first += 8) {
    const std::uint32_t lanes = std::min<std::uint32_t>(8, count - first);
    const __m256 laneBits = lanes < 8 ? laneMask(lanes) : _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    __m256 x, y, z;
    loadPositions(particles, neighbors + first, lanes, x, y, z);
    const __m256i index =  // the lanes' neighbour indices (none read past the list)
        _mm256_maskload_epi32(reinterpret_cast<const int*>(neighbors + first), _mm256_castps_si256(laneBits));
    if (withFluid) {
      const __m256 dx = _mm256_sub_ps(qx, x), dy = _mm256_sub_ps(qy, y), dz = _mm256_sub_ps(qz, z);
      const __m256 r2 =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      const __m256 within = _mm256_and_ps(_mm256_cmp_ps(r2, h2, _CMP_LT_OQ), laneBits);
      sum = _mm256_add_ps(sum, _mm256_and_ps(valueShapeAvx2<K>(k, r2), within));
    }
    for (int m = 0; m < images.count; ++m) {
      const Vec3r& p = images.preImage[m];
      const __m256 dx = _mm256_sub_ps(_mm256_set1_ps(p.x()), x), dy = _mm256_sub_ps(_mm256_set1_ps(p.y()), y),
                   dz = _mm256_sub_ps(_mm256_set1_ps(p.z()), z);
      const __m256 r2 =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      const unsigned keep =
          unsigned(_mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(r2, keepRadius2, _CMP_LT_OQ), laneBits)));
      const __m256 within = _mm256_and_ps(_mm256_cmp_ps(r2, h2, _CMP_LT_OQ), laneBits);
      imageSum[m] = _mm256_add_ps(imageSum[m], _mm256_and_ps(valueShapeAvx2<K>(k, r2), within));
      // The kept lanes' indices packed to the front, stored whole (the room has 8 to spare).
      const __m256i packed = _mm256_permutevar8x32_epi32(
          index, _mm256_load_si256(reinterpret_cast<const __m256i*>(compress[keep])));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(images.kept[m] + kept[m]), packed);
      kept[m] += unsigned(__builtin_popcount(keep));
    }
  }
  for (int m = 0; m < images.count; ++m) images.sum[m] = horizontalSum(imageSum[m]), images.keptCount[m] = kept[m];
  return horizontalSum(sum);
}

std::atomic<bool> gAvx2Allowed{true};

bool wcsphUsesAvx2() {
  static const bool supported = __builtin_cpu_supports("avx2");
  return supported && gAvx2Allowed.load(std::memory_order_relaxed);
}

/// Whether the force loop runs in its AVX-512VL build (CASCADE_NO_AVX512 set: never).
std::atomic<bool> gAvx512Allowed{true};

bool wcsphUsesAvx512Registers() {
  static const bool supported = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                                std::getenv("CASCADE_NO_AVX512") == nullptr;
  return supported && gAvx512Allowed.load(std::memory_order_relaxed);
}
#endif

template <KernelPair K>
ForceSums forceSums(const ForceConstants& k, const wcsph::PairInput* particles, const ForceQuery& q,
                    const std::uint32_t* neighbors, std::uint32_t count) {
#ifdef CASCADE_WCSPH_AVX2
  if (wcsphUsesAvx2())
    return wcsphUsesAvx512Registers() ? forceSumsAvx512Registers<K>(k, particles, q, neighbors, count)
                                      : forceSumsAvx2<K>(k, particles, q, neighbors, count);
#endif
  return forceSumsScalar<K>(k, particles, q, neighbors, count);
}

ForceSums forceSums(const ForceConstants& k, const wcsph::PairInput* particles, const ForceQuery& q,
                    const std::uint32_t* neighbors, std::uint32_t count) {
  switch (k.kernel.pair) {
    case KernelPair::Mueller2003: return forceSums<KernelPair::Mueller2003>(k, particles, q, neighbors, count);
    case KernelPair::CubicSpline: return forceSums<KernelPair::CubicSpline>(k, particles, q, neighbors, count);
    case KernelPair::Automatic:  // chosen in Simulation::start
    case KernelPair::WendlandC2: return forceSums<KernelPair::WendlandC2>(k, particles, q, neighbors, count);
  }
  return {};
}

template <KernelPair K>
Real kernelSum(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q,
               const std::uint32_t* neighbors, std::uint32_t count) {
#ifdef CASCADE_WCSPH_AVX2
  if (wcsphUsesAvx2()) return kernelSumAvx2<K>(k, particles, q, neighbors, count);
#endif
  return kernelSumScalar<K>(k, particles, q, neighbors, count);
}

template <KernelPair K>
Real kernelSumImages(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q, bool withFluid,
                     const std::uint32_t* neighbors, std::uint32_t count, Real keep2, FusedImages& images) {
#ifdef CASCADE_WCSPH_AVX2
  if (wcsphUsesAvx2()) return kernelSumImagesAvx2<K>(k, particles, q, withFluid, neighbors, count, keep2, images);
#endif
  return kernelSumImagesScalar<K>(k, particles, q, withFluid, neighbors, count, keep2, images);
}

/// The fluid sum around q (if withFluid) and the images' sums and kept lists
/// (FusedImages) in one pass over neighbours[0 .. count).
Real kernelSumImages(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q, bool withFluid,
                     const std::uint32_t* neighbors, std::uint32_t count, Real keep2, FusedImages& images) {
  switch (k.pair) {
    case KernelPair::Mueller2003:
      return kernelSumImages<KernelPair::Mueller2003>(k, particles, q, withFluid, neighbors, count, keep2, images);
    case KernelPair::CubicSpline:
      return kernelSumImages<KernelPair::CubicSpline>(k, particles, q, withFluid, neighbors, count, keep2, images);
    case KernelPair::Automatic:  // chosen in Simulation::start
    case KernelPair::WendlandC2:
      return kernelSumImages<KernelPair::WendlandC2>(k, particles, q, withFluid, neighbors, count, keep2, images);
  }
  return 0;
}

/// sum_j W_ij / valueCoeff over neighbours[0 .. count) within h of q.
Real kernelSum(const KernelConstants& k, const wcsph::PairInput* particles, const Vec3r& q,
               const std::uint32_t* neighbors, std::uint32_t count) {
  switch (k.pair) {
    case KernelPair::Mueller2003: return kernelSum<KernelPair::Mueller2003>(k, particles, q, neighbors, count);
    case KernelPair::CubicSpline: return kernelSum<KernelPair::CubicSpline>(k, particles, q, neighbors, count);
    case KernelPair::Automatic:  // chosen in Simulation::start
    case KernelPair::WendlandC2: return kernelSum<KernelPair::WendlandC2>(k, particles, q, neighbors, count);
  }
  return 0;
}

/// W / valueCoeff of one pair within h.
Real valueShape(const KernelConstants& k, Real r2) {
  switch (k.pair) {
    case KernelPair::Mueller2003: return valueShape<KernelPair::Mueller2003>(k, r2);
    case KernelPair::CubicSpline: return valueShape<KernelPair::CubicSpline>(k, r2);
    case KernelPair::Automatic:  // chosen in Simulation::start
    case KernelPair::WendlandC2: return valueShape<KernelPair::WendlandC2>(k, r2);
  }
  return 0;
}

/// g with grad W(r) = g r_vec for the density kernel W (0 < |r| < h): the
/// derivative of the summed density, for the continuity equation.
Real densityGradient(const KernelConstants& k, Real r2) {
  if (k.pair == KernelPair::Mueller2003) {
    const Real d = k.supportRadius2 - r2;  // poly6: grad (h^2 - r^2)^3 = -6 (h^2 - r^2)^2 r_vec
    return Real(-6) * k.valueCoeff * d * d;
  }
  const Real len = std::sqrt(r2);
  return k.gradientCoeff * (k.pair == KernelPair::CubicSpline ? gradientShape<KernelPair::CubicSpline>(k, len)
                                                              : gradientShape<KernelPair::WendlandC2>(k, len));
}

/// The kernel pair with its lattice normalisation (cached in the workspace):
/// the density scale makes the rest lattice of the fluid spacing exactly rho_0
/// (the SEED pair: the particle mass, derived from poly6 the same way), and the
/// gradient correction 1 / C of DerivedConstants for the chosen gradient.
const wcsph::KernelNormalisation& kernelNormalisation(const StepContext& c, wcsph::Workspace& workspace) {
  wcsph::KernelNormalisation& n = workspace.normalisation;
  const KernelPair pair = c.settings.solver.kernels;
  const Real h = c.constants.supportRadius, spacing = c.settings.fluid.spacing;
  if (n.valid && n.pair == pair && n.supportRadius == h && n.spacing == spacing &&
      n.particleMass == c.constants.particleMass)
    return n;
  n.pair = pair;
  n.supportRadius = h;
  n.spacing = spacing;
  n.particleMass = c.constants.particleMass;
  const KernelConstants k(pair, h);
  if (pair == KernelPair::Mueller2003) {
    n.densityScale = c.constants.particleMass;  // rho_0 / sum poly6 (Simulation)
    n.gradientCorrection = c.constants.gradientCorrection;
  } else {
    LatticeSums sums;
    if (pair == KernelPair::CubicSpline) sums = latticeSums<KernelPair::CubicSpline>(k, spacing);
    else sums = latticeSums<KernelPair::WendlandC2>(k, spacing);
    n.densityScale = static_cast<Real>(double(c.settings.fluid.restDensity) / sums.value);
    // C with V = m / rho_0 (the force uses the particle mass m): m / C is then
    // rho_0 / (-(1/3) sum_j (x_i - x_j) . grad W), independent of m.
    n.gradientCorrection = static_cast<Real>(
        1.0 / (sums.gradient * double(c.constants.particleMass) / double(c.settings.fluid.restDensity)));
  }
  n.valid = true;
  return n;
}

ForceConstants forceConstants(const StepContext& c, const wcsph::Workspace& workspace) {
  const SolverSettings& solver = c.settings.solver;
  const Real h = c.constants.supportRadius;
  ForceConstants k;
  k.kernel = KernelConstants(solver.kernels, h);
  const Real halved = solver.pressureForce == PressureForce::MuellerHalf ? Real(0.5) : Real(1);
  k.pressureCoeff = -c.constants.particleMass * halved * workspace.normalisation.gradientCorrection;
  // Monaghan 1992: Pi_ij = -alpha h c (v_ij . r_ij) / (rho_avg (r^2 + 0.01 h^2)), times -m.
  const Real alpha = solver.artificialViscosity * h * c.constants.speedOfSound;
  k.artificialCoeff = Real(2) * c.constants.particleMass * alpha;
  k.epsilon2 = Real(0.01) * h * h;
  k.hamiltonian = solver.pressureForce == PressureForce::Hamiltonian;
  k.artificial = alpha > 0;
  k.viscous = c.settings.fluid.viscosity > 0;
  k.allPairs = solver.artificialViscosityAllPairs;
  return k;
}

/// mu m lap W_visc / (h - r) of SEED (6), (9): the viscosity sum's factor.
Real viscosityFactor(const StepContext& c) {
  return c.settings.fluid.viscosity * c.constants.particleMass *
         KernelViscosity(c.constants.supportRadius).laplacianCoeff;
}

/// Whether `linear` is orthogonal (a reflection or a product of them), so the
/// mirror passes may work in the mirror's frame.
bool isOrthogonal(const Eigen::Matrix<Real, 3, 3>& linear) {
  return ((linear.transpose() * linear) - Eigen::Matrix<Real, 3, 3>::Identity()).cwiseAbs().maxCoeff() <= Real(1e-4);
}

/// How the mirror passes sum the type II images (SEED section 2.2) that `map` makes of
/// a layer particle's neighbours. An orthogonal map over a whole half-space is an
/// isometry: |x_i - (M x_j + o)| = |y - x_j| with y = M^T (x_i - o), so the sum over
/// the images is the fluid sum around i's pre-image y (true). Any other map (a mesh
/// face's, imaging only the fluid in front of it) is summed image by image.
bool sumsAroundPreImage(const MirrorMap& map) { return isOrthogonal(map.linear) && !map.frontOnly; }

/// i's pre-image y = M^T (x_i - o) (sumsAroundPreImage).
Vec3r preImage(const MirrorMap& map, const Vec3r& xi) { return map.linear.transpose() * (xi - map.offset); }

} // namespace

namespace wcsph {

void gatherPairInputs(StepContext& c, Workspace& workspace) {
  Particles& particles = c.particles;
  const std::size_t n = particles.size();
  workspace.particles.resize(n);
  PairInput* records = workspace.particles.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3r& x = particles.position[i];
      const Vec3r& v = particles.velocity[i];
      records[i].x = x.x();
      records[i].y = x.y();
      records[i].z = x.z();
      records[i].vx = v.x();
      records[i].vy = v.y();
      records[i].vz = v.z();
    }
  });
  kernelNormalisation(c, workspace);
}

namespace {
/// Sizes the mirror pairs of this step's maps (Workspace::mirrorNeighbors): room for
/// every neighbour under every map of the boundary layer, and per map whether its
/// passes sum around the pre-image.
void prepareMirrorPairs(const StepContext& c, Workspace& workspace) {
  const BoundaryParticles& boundary = c.boundary;
  const std::vector<MirrorMap>& maps = boundary.mirrors();
  workspace.mirrorBegin.resize(maps.size());
  workspace.mirrorCount.assign(maps.size(), 0);
  workspace.mirrorPreImage.resize(maps.size());
  if (maps.empty()) return;
  const std::vector<std::uint32_t>& layer = boundary.layer();
  const std::vector<std::uint32_t>& mapOffsets = boundary.mirrorOffsets();
  const NeighborLists& nl = c.neighbors;
  // A prefix sum over chunks of the layer. Each map's room has 8 entries to spare:
  // the vector loops store kept indices eight at a time.
  constexpr std::size_t kChunk = 1024, kRoomSpare = 8;
  const std::size_t chunks = (layer.size() + kChunk - 1) / kChunk;
  std::vector<std::size_t> chunkStart(chunks + 1, 0);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    std::size_t room = 0;
    for (std::size_t k = chunk * kChunk, end = std::min(layer.size(), k + kChunk); k < end; ++k)
      room += std::size_t(boundary.mirrorCount(layer[k])) * (nl.count(layer[k]) + kRoomSpare);
    chunkStart[chunk + 1] = room;
  });
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) chunkStart[chunk + 1] += chunkStart[chunk];
  if (chunkStart[chunks] > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("WCSPH mirror pairs: more than 2^32 candidates in one step");
  workspace.mirrorNeighbors.resize(chunkStart[chunks]);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    std::size_t next = chunkStart[chunk];
    for (std::size_t k = chunk * kChunk, end = std::min(layer.size(), k + kChunk); k < end; ++k) {
      const std::uint32_t i = layer[k];
      for (std::uint32_t m = mapOffsets[i]; m < mapOffsets[i + 1]; ++m) {
        workspace.mirrorBegin[m] = static_cast<std::uint32_t>(next);
        workspace.mirrorPreImage[m] = sumsAroundPreImage(maps[m]);
        next += nl.count(i) + kRoomSpare;
      }
    }
  });
}

/// For layer particle i: the sum of W / valueCoeff over its fluid neighbours (if
/// `fluid` is not null) and over the mirror images of itself and its neighbours
/// under each of its maps, in one pass over the neighbours for the fluid and up to
/// kFusedImages maps summed around pre-images (more take more passes); writes each
/// map's mirror pairs (Workspace::mirrorNeighbors). Returns the images' sum, added
/// map by map in map order.
Real densityWithImages(const StepContext& c, const KernelConstants& kernel, const PairInput* records,
                       std::uint32_t i, Real keep2, Workspace& workspace, Real* fluid) {
  const std::vector<MirrorMap>& maps = c.boundary.mirrors();
  const std::uint32_t mapBegin = c.boundary.mirrorOffsets()[i], mapEnd = c.boundary.mirrorOffsets()[i + 1];
  const NeighborLists& nl = c.neighbors;
  const Real h2 = kernel.supportRadius2;
  const Vec3r xi(records[i].x, records[i].y, records[i].z);
  // Each pre-image map's sum, by its place among i's maps.
  constexpr std::uint32_t kInline = 32;
  Real inlineSums[kInline];
  std::vector<Real> manySums(mapEnd - mapBegin > kInline ? mapEnd - mapBegin : 0);
  Real* imageSums = manySums.empty() ? inlineSums : manySums.data();
  FusedImages images;
  std::uint32_t slot[kFusedImages];
  bool fluidDone = fluid == nullptr;
  const auto flush = [&] {
    const Real sum = kernelSumImages(kernel, records, xi, !fluidDone, nl.begin(i), nl.count(i), keep2, images);
    if (!fluidDone) *fluid = sum, fluidDone = true;
    for (int f = 0; f < images.count; ++f) {
      imageSums[slot[f]] = images.sum[f];
      workspace.mirrorCount[mapBegin + slot[f]] = images.keptCount[f];
    }
    images.count = 0;
  };
  for (std::uint32_t m = mapBegin; m < mapEnd; ++m) {
    if (!workspace.mirrorPreImage[m]) continue;
    images.preImage[images.count] = preImage(maps[m], xi);
    images.kept[images.count] = workspace.mirrorNeighbors.data() + workspace.mirrorBegin[m];
    slot[images.count++] = m - mapBegin;
    if (images.count == kFusedImages) flush();
  }
  if (images.count > 0 || !fluidDone) flush();
  Real sum = 0;
  for (std::uint32_t m = mapBegin; m < mapEnd; ++m) {
    const MirrorMap& map = maps[m];
    // The mirror of i itself, then of each neighbour.
    const Real self2 = squaredDistance(xi, map.apply(xi));
    if (self2 < h2) sum += valueShape(kernel, self2);
    if (workspace.mirrorPreImage[m]) {
      sum += imageSums[m - mapBegin];
      continue;
    }
    // Image by image: only of the fluid in front of a front-only map.
    std::uint32_t* out = workspace.mirrorNeighbors.data() + workspace.mirrorBegin[m];
    std::uint32_t kept = 0;
    for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j) {
      const Vec3r xj(records[*j].x, records[*j].y, records[*j].z);
      if (map.behind(xi, xj)) continue;  // its image would lie in the fluid
      const Real r2 = squaredDistance(xi, map.apply(xj));
      if (r2 < h2) sum += valueShape(kernel, r2);
      if (r2 < keep2) out[kept++] = *j;
    }
    workspace.mirrorCount[m] = kept;
  }
  return sum;
}

/// Kept mirror pairs: images within h, with a margin of 1e-4 h^2 so that every later
/// pass's own test (around the pre-image, or image by image) finds all its pairs among them.
Real mirrorKeepRadius2(const KernelConstants& kernel) { return Real(1.0001) * kernel.supportRadius2; }

/// Checks that the mirror pairs were collected for this step's maps.
void requireMirrorNeighbors(const StepContext& c, const Workspace& workspace) {
  if (workspace.mirrorCount.size() != c.boundary.mirrors().size())
    throw std::logic_error("WCSPH: the mirror passes need the mirror pairs of this step's maps");
}
} // namespace

void collectMirrorNeighbors(StepContext& c, Workspace& workspace) {
  prepareMirrorPairs(c, workspace);
  if (c.boundary.mirrors().empty()) return;
  const KernelConstants kernel(c.settings.solver.kernels, c.constants.supportRadius);
  const Real keep2 = mirrorKeepRadius2(kernel);
  const PairInput* records = workspace.particles.data();
  const std::vector<std::uint32_t>& layer = c.boundary.layer();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, layer.size(), 256), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k)
      if (c.boundary.mirrorCount(layer[k]) > 0) densityWithImages(c, kernel, records, layer[k], keep2, workspace, nullptr);
  });
}

void computeFluidDensity(StepContext& c, Workspace& workspace) {
  gatherPairInputs(c, workspace);
  prepareMirrorPairs(c, workspace);
  Particles& particles = c.particles;
  const PairInput* records = workspace.particles.data();
  const KernelConstants kernel(c.settings.solver.kernels, c.constants.supportRadius);
  const Real scale = workspace.normalisation.densityScale;
  const Real self = valueShape(kernel, 0);
  const Real keep2 = mirrorKeepRadius2(kernel);
  const NeighborLists& nl = c.neighbors;
  const bool mirrors = !c.boundary.mirrors().empty();
  // The owned particles (over MPI ranks the halo's densities come from their owners).
  forEachInListOrder(nl, c.ownedCount(), 512, [&](std::size_t i) {
    if (!mirrors || c.boundary.mirrorCount(i) == 0) {
      // i's own position from its record (a neighbour's too, so likely cached when the
      // list order visits i out of particle order), the same floats as particles.position.
      const Vec3r xi(records[i].x, records[i].y, records[i].z);
      const Real sum = kernelSum(kernel, records, xi, nl.begin(i), nl.count(i));
      particles.density[i] = scale * kernel.valueCoeff * (self + sum);  // SEED (4)
      return;
    }
    // The boundary layer: the fluid and its type II images in one pass.
    Real sum = 0;
    const Real images = densityWithImages(c, kernel, records, std::uint32_t(i), keep2, workspace, &sum);
    particles.density[i] = scale * kernel.valueCoeff * (self + sum);  // SEED (4)
    particles.density[i] += scale * kernel.valueCoeff * images;
  });
}

void computePressure(StepContext& c, Workspace& workspace) {
  PressureModel model;
  model.equation = c.settings.solver.equationOfState;
  model.restDensity = c.settings.fluid.restDensity;
  model.stiffness = c.constants.stiffness;
  model.exponent = c.settings.solver.taitExponent;
  model.clampNegative = c.settings.solver.clampNegativePressure;
  Particles& particles = c.particles;
  PairInput* records = workspace.particles.data();
  // Surface layer (SolverSettings::surfaceLayerPressure): p >= rho_0 |g| s / 2 for
  // particles of a water body (rho >= 0.8 rho_0), not for spray.
  const bool surfaceLayer = c.settings.solver.surfaceLayerPressure && model.clampNegative &&
                            c.settings.solver.density == DensityEvolution::Summation;
  const Real surfacePressure = surfaceLayer ? Real(0.5) * c.settings.fluid.restDensity *
                                                  c.settings.solver.gravity.norm() * c.settings.fluid.spacing
                                            : Real(0);
  const Real bodyDensity = Real(kSurfaceLayerDensity) * c.settings.fluid.restDensity;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 2048), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      particles.pressure[i] = model(particles.density[i]);
      if (surfaceLayer && particles.density[i] >= bodyDensity)
        particles.pressure[i] = std::max(particles.pressure[i], surfacePressure);
      records[i].pressure = particles.pressure[i];
      records[i].density = particles.density[i];
    }
  });
  refreshGhostPressure(c, workspace);
}

void refreshGhostPressure(StepContext& c, Workspace& workspace) {
  if (c.partition == nullptr) return;
  Particles& particles = c.particles;
  const std::size_t owned = c.ownedCount();
  c.partition->refreshGhosts(particles.density.data(), owned);
  c.partition->refreshGhosts(particles.pressure.data(), owned);
  PairInput* records = workspace.particles.data();
  for (std::size_t i = owned; i < particles.size(); ++i) {
    records[i].pressure = particles.pressure[i];
    records[i].density = particles.density[i];
  }
}

void computeDensityRate(StepContext& c, Workspace& workspace) {
  const std::size_t n = c.particles.size();
  workspace.densityRate.resize(n);
  Real* rate = workspace.densityRate.data();
  const KernelConstants kernel(c.settings.solver.kernels, c.constants.supportRadius);
  const Real mass = workspace.normalisation.densityScale;  // m of SEED (4)
  const Real h2 = kernel.supportRadius2;
  // 2 delta h c_0, h the smoothing length (half the support radius)
  const Real diffusion = Real(2) * c.settings.solver.densityDiffusion * Real(0.5) * kernel.supportRadius *
                         c.constants.speedOfSound;
  // rho^H_i - rho^H_j = rho_0 g . x_ij / c_0^2 (Fourtakas et al. 2019, linearised EOS)
  const Vec3r hydrostatic = (c.settings.fluid.restDensity / c.constants.stiffness) * c.settings.solver.gravity;
  const PairInput* records = workspace.particles.data();
  const NeighborLists& nl = c.neighbors;
  forEachInListOrder(nl, n, 512, [&](std::size_t i) {
    const PairInput& p = records[i];
    Real divergence = 0, laplacian = 0;
    for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j) {
      const PairInput& q = records[*j];
      const Vec3r r(p.x - q.x, p.y - q.y, p.z - q.z);
      const Real r2 = r.squaredNorm();
      if (r2 >= h2 || r2 <= Real(0)) continue;
      const Real g = densityGradient(kernel, r2);  // grad W_ij = g x_ij
      divergence += g * ((p.vx - q.vx) * r.x() + (p.vy - q.vy) * r.y() + (p.vz - q.vz) * r.z());
      laplacian += g * (p.density - q.density - hydrostatic.dot(r)) / q.density;
    }
    rate[i] = mass * (divergence + diffusion * laplacian);
  });
  // The mirror images (as computeFluidDensity sums them): the same continuity sum, over
  // the mirror pairs (collectMirrorNeighbors).
  const BoundaryParticles& boundary = c.boundary;
  if (boundary.mirrors().empty()) return;
  requireMirrorNeighbors(c, workspace);
  const std::vector<std::uint32_t>& layer = boundary.layer();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, layer.size(), 256), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const std::uint32_t i = layer[k];
      const PairInput& p = records[i];
      const Vec3r xi(p.x, p.y, p.z), vi(p.vx, p.vy, p.vz);
      Real sum = 0;
      auto add = [&](const Vec3r& x, const Vec3r& v, const Vec3r& y, const Vec3r& u) {
        const Vec3r r = x - y;
        const Real r2 = r.squaredNorm();
        if (r2 < h2 && r2 > Real(0)) sum += densityGradient(kernel, r2) * (v - u).dot(r);
      };
      for (std::uint32_t m = boundary.mirrorOffsets()[i]; m < boundary.mirrorOffsets()[i + 1]; ++m) {
        const MirrorMap& map = boundary.mirrors()[m];
        const std::uint32_t* list = workspace.mirrorList(m);
        const std::uint32_t* const listEnd = list + workspace.mirrorCount[m];
        add(xi, vi, map.apply(xi), map.imageVelocity(vi, false));
        if (workspace.mirrorPreImage[m]) {
          // Around i's pre-image y, with v_i - (w + M (v_j - w)) = M (u - v_j) for the
          // velocities: the fluid sum around (y, u), u = M^T (v_i - w) + w.
          const Vec3r y = preImage(map, xi);
          const Vec3r u = map.linear.transpose() * (vi - map.wallVelocity) + map.wallVelocity;
          for (const std::uint32_t* j = list; j != listEnd; ++j) {
            const PairInput& q = records[*j];
            add(y, u, Vec3r(q.x, q.y, q.z), Vec3r(q.vx, q.vy, q.vz));
          }
        } else {
          for (const std::uint32_t* j = list; j != listEnd; ++j) {
            const PairInput& q = records[*j];
            add(xi, vi, map.apply(Vec3r(q.x, q.y, q.z)), map.imageVelocity(Vec3r(q.vx, q.vy, q.vz), false));
          }
        }
      }
      rate[i] += mass * sum;
    }
  });
}

namespace {
/// L(f)_i = sum_j V_0 W_ij (f_j - f_i) over i's fluid neighbours and, for the boundary
/// layer, the mirror images of i and of its neighbours, an image carrying a + M f_j
/// (a = (I - M) w for the velocity of a wall moving at w, free slip; a = 0 for a
/// velocity difference). V_0 = m / rho_0, so the pair weights are symmetric. The fluid
/// pairs' W / valueCoeff go to pairWeights, at each list entry's index, when fillWeights,
/// and are read from there otherwise (the second pass of the same step).
template <class Field, class ImageOffset>
void velocityFilterLaplacian(StepContext& c, const Workspace& workspace, const KernelConstants& kernel, Field&& field,
                             ImageOffset&& imageOffset, std::vector<Vec3r>& out, std::vector<Real>& pairWeights,
                             bool fillWeights) {
  const NeighborLists& nl = c.neighbors;
  const PairInput* records = workspace.particles.data();
  const Real weight = workspace.normalisation.densityScale / c.settings.fluid.restDensity * kernel.valueCoeff;
  const Real h2 = kernel.supportRadius2;
  const std::size_t n = c.particles.size();
  out.assign(n, Vec3r::Zero());
  if (fillWeights) pairWeights.resize(nl.indices.size());
  forEachInListOrder(nl, n, 512, [&](std::size_t i) {
    const PairInput& p = records[i];
    const Vec3r fi = field(i);
    Vec3r sum = Vec3r::Zero();
    Real* w = pairWeights.data() + nl.offsets[i];
    for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j, ++w) {
      if (fillWeights) {
        const PairInput& q = records[*j];
        const Real r2 = squaredDistance(Vec3r(p.x, p.y, p.z), Vec3r(q.x, q.y, q.z));
        *w = r2 < h2 && r2 > Real(0) ? valueShape(kernel, r2) : Real(0);
      }
      sum += *w * (field(*j) - fi);
    }
    out[i] = weight * sum;
  });
  const BoundaryParticles& boundary = c.boundary;
  if (boundary.mirrors().empty()) return;
  const std::vector<std::uint32_t>& layer = boundary.layer();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, layer.size(), 256), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const std::uint32_t i = layer[k];
      const PairInput& p = records[i];
      const Vec3r xi(p.x, p.y, p.z), fi = field(i);
      Vec3r sum = Vec3r::Zero();
      for (std::uint32_t m = boundary.mirrorOffsets()[i]; m < boundary.mirrorOffsets()[i + 1]; ++m) {
        const MirrorMap& map = boundary.mirrors()[m];
        const Vec3r a = imageOffset(map);
        const std::uint32_t* list = workspace.mirrorList(m);
        const std::uint32_t* const listEnd = list + workspace.mirrorCount[m];
        const Real self2 = squaredDistance(xi, map.apply(xi));
        if (self2 < h2 && self2 > Real(0)) sum += valueShape(kernel, self2) * (a + map.linear * fi - fi);
        if (workspace.mirrorPreImage[m]) {
          // Around i's pre-image y (an isometry): a + M f_j - f_i = M (f_j - u), u = M^T (f_i - a).
          const Vec3r y = preImage(map, xi), u = map.linear.transpose() * (fi - a);
          Vec3r local = Vec3r::Zero();
          for (const std::uint32_t* j = list; j != listEnd; ++j) {
            const PairInput& q = records[*j];
            const Real r2 = squaredDistance(y, Vec3r(q.x, q.y, q.z));
            if (r2 < h2 && r2 > Real(0)) local += valueShape(kernel, r2) * (field(*j) - u);
          }
          sum += map.linear * local;
        } else {
          for (const std::uint32_t* j = list; j != listEnd; ++j) {
            const PairInput& q = records[*j];
            const Real r2 = squaredDistance(xi, map.apply(Vec3r(q.x, q.y, q.z)));
            if (r2 < h2 && r2 > Real(0)) sum += valueShape(kernel, r2) * (a + map.linear * field(*j) - fi);
          }
        }
      }
      out[i] += weight * sum;
    }
  });
}
} // namespace

int velocityFilterInterval(const SolverSettings& solver) {
  // beta c_0 / h dt is about beta cfl per step (dt = cfl h / (c_0 + v)); L^2 is at most
  // about 4, so K beta cfl <= 0.2 keeps each application below 0.8 of a zigzag's velocity.
  const double perStep = double(solver.velocityFilter) * std::max(double(solver.cflFactor), 0.05);
  return perStep > 0 ? std::clamp(int(0.2 / perStep), 1, 8) : 1;
}

void addVelocityFilter(StepContext& c, Workspace& workspace) {
  const Real beta = c.settings.solver.velocityFilter;
  if (beta <= Real(0)) return;
  const int interval = velocityFilterInterval(c.settings.solver);
  if (c.step % std::uint64_t(interval) != 0) return;
  if (!c.boundary.mirrors().empty()) requireMirrorNeighbors(c, workspace);
  const KernelConstants kernel(c.settings.solver.kernels, c.constants.supportRadius);
  const PairInput* records = workspace.particles.data();
  velocityFilterLaplacian(
      c, workspace, kernel, [&](std::size_t j) { return Vec3r(records[j].vx, records[j].vy, records[j].vz); },
      [](const MirrorMap& map) { return Vec3r(map.wallVelocity - map.linear * map.wallVelocity); },
      workspace.velocityLaplacian, workspace.filterWeights, true);
  if (c.partition) c.partition->refreshGhosts(workspace.velocityLaplacian.data(), c.ownedCount());
  const std::vector<Vec3r>& laplacian = workspace.velocityLaplacian;
  velocityFilterLaplacian(
      c, workspace, kernel, [&](std::size_t j) { return laplacian[j]; },
      [](const MirrorMap&) { return Vec3r(Vec3r::Zero()); }, workspace.velocityBilaplacian, workspace.filterWeights,
      false);
  // a_i -= K beta c_0 / h L(L(v))_i on every K-th step
  const Real coeff = Real(interval) * beta * c.constants.speedOfSound / c.constants.supportRadius;
  const std::vector<Vec3r>& bilaplacian = workspace.velocityBilaplacian;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, c.ownedCount(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) c.acceleration[i] -= coeff * bilaplacian[i];
  });
}

void computeFluidAcceleration(StepContext& c, const Workspace& workspace) {
  const Particles& particles = c.particles;
  const ForceConstants k = forceConstants(c, workspace);
  const Real viscosityCoeff = viscosityFactor(c);
  const NeighborLists& nl = c.neighbors;
  const Vec3r gravity = c.settings.solver.gravity;
  std::vector<Vec3r>& acceleration = c.acceleration;
  acceleration.resize(particles.size());
  const PairInput* records = workspace.particles.data();
  forEachInListOrder(nl, c.ownedCount(), 512, [&](std::size_t i) {
    const PairInput& p = records[i];
    const Real invRhoi = Real(1) / p.density;
    const ForceQuery q{p.x, p.y, p.z, p.vx, p.vy, p.vz, p.pressure, p.density, invRhoi};
    const ForceSums sums = forceSums(k, records, q, nl.begin(i), nl.count(i));
    // SEED (6) / rho_i: mu m (v_j - v_i) / (rho_j rho_i) lap W_visc
    acceleration[i] = gravity + sums.pressure - (viscosityCoeff * invRhoi) * sums.viscous;
  });
}

namespace {
/// The hydrostatic part of the mirror images' pressure (Adami et al. 2012, eq. 27, for a
/// wall at rest): an image at x'_j = M x_j + o lies deeper or shallower than its source
/// x_j, so its pressure is p_j + rho_0 g . (x'_j - x_j), not p_j. Returns the pressure
/// term of that difference alone (addPairTerms with no velocities and no pressure of i's)
/// summed over i's own image and those of the listed neighbours (the images' own
/// pressures are in the main sums).
Vec3r imageHydrostaticSum(const ForceConstants& k, const MirrorMap& map, const Vec3r& xi, Real rhoi,
                          const wcsph::PairInput* records, std::uint32_t self, const std::uint32_t* list,
                          std::uint32_t count, const Vec3r& rho0g) {
  const ForceQuery q{xi.x(), xi.y(), xi.z(), 0, 0, 0, 0, rhoi, Real(1) / rhoi};
  ForceSums sums;
  const auto add = [&](const wcsph::PairInput& pj) {
    const Vec3r xj(pj.x, pj.y, pj.z), image = map.apply(xj);
    addPairTerms(k, q, wcsph::PairInput{image.x(), image.y(), image.z(), rho0g.dot(image - xj), 0, 0, 0, pj.density},
                 sums);
  };
  add(records[self]);
  for (std::uint32_t n = 0; n < count; ++n) add(records[list[n]]);
  return sums.pressure;
}
} // namespace

void addBoundaryAcceleration(StepContext& c, const Workspace& workspace, Real timeStep) {
  const BoundaryParticles& boundary = c.boundary;
  const Particles& particles = c.particles;
  const std::vector<std::uint32_t>& layer = boundary.layer();
  const std::size_t boundaryCount = c.obstacleForce.size();
  std::fill(c.obstacleForce.begin(), c.obstacleForce.end(), Vec3d::Zero());
  std::fill(c.obstacleMoment.begin(), c.obstacleMoment.end(), Vec3d::Zero());
  if (layer.empty() && c.partition == nullptr) return;  // over ranks the sums below are collective
  const ForceConstants k = forceConstants(c, workspace);
  const Real viscosityCoeff = viscosityFactor(c);
  const PairInput* records = workspace.particles.data();
  if (!boundary.mirrors().empty()) requireMirrorNeighbors(c, workspace);
  const bool noSlip = c.settings.boundary.slip == MirrorSlip::NoSlip;
  const Real r0 = c.constants.repulsionRadius, r02 = r0 * r0;
  const Real strength = c.constants.repulsionStrength;
  const Real minR2 = Real(0.04) * r02;  // SEED (11) is singular at r = 0; cap at r = 0.2 r0
  const Real contactSpeed = Real(0.5) * c.constants.expectedSpeed;
  // One solid: SEED (11) with D = v_expected^2 stops particles up to the expected
  // speed in time; faster impacts (spray off a long slope, the tower at 7 m/s) get
  // the limiter, up to a quarter of the instability speed. Beyond that the flow is
  // out of the scene's range (an overpressure blast) and the instability stop reports it.
  const Real fastApproach = c.constants.expectedSpeed;
  const Real blastApproach = Real(0.25) * c.settings.solver.instabilitySpeedFactor * c.constants.expectedSpeed;
  // Per entry of the type I lists: the sample, its position and its solid.
  const NeighborLists& sampleLists = boundary.sampleNeighbors();
  const std::vector<Vec3r>& samples = boundary.sampleNeighborPositions();
  const std::vector<std::uint32_t>& owners = boundary.sampleNeighborOwners();
  const Real mass = c.constants.particleMass;
  const bool hydrostaticImages = c.settings.boundary.mirrorHydrostatic;
  const Vec3r rho0g = c.settings.fluid.restDensity * c.settings.solver.gravity;

  // Force and moment on each solid, the same in every run and on any rank count.
  ReactionSums reactions(layer.size(), boundaryCount, 2, c.partition);
  tbb::parallel_for(std::size_t(0), ReactionSums::chunks(layer.size()), [&](std::size_t chunk) {
    const std::size_t end = std::min(layer.size(), (chunk + 1) * ReactionSums::kChunk);
    const std::size_t owned = c.ownedCount();
    for (std::size_t kk = chunk * ReactionSums::kChunk; kk < end; ++kk) {
      const std::uint32_t i = layer[kk];
      if (i >= owned) continue;  // a ghost: its owner moves it
      Vec3d* const force = reactions.record(kk);
      Vec3d* const moment = force + boundaryCount;
      const auto react = [&](std::uint32_t owner, const Vec3d& f, const Vec3r& at) {
        force[owner] += f;
        moment[owner] += at.cast<double>().cross(f);
      };
      const Vec3r xi = particles.position[i], vi = particles.velocity[i];
      const Real pi = particles.pressure[i], rhoi = particles.density[i];
      Vec3r total = Vec3r::Zero();
      // Type II: mirror particles of i and its neighbours.
      for (std::uint32_t m = boundary.mirrorOffsets()[i]; m < boundary.mirrorOffsets()[i + 1]; ++m) {
        const MirrorMap& map = boundary.mirrors()[m];
        Vec3r a = Vec3r::Zero();
        if (!noSlip && workspace.mirrorPreImage[m]) {
          // Free slip: the mirror of j at M x_j + o with velocity w + M (v_j - w) (w
          // the wall's velocity). With y = M^T (x_i - o) and u = M^T (v_i - w) + w,
          // x_i - M x_j - o = M (y - x_j) and v_i - w - M (v_j - w) = M (u - v_j):
          // the fluid sums around (y, u), turned by M.
          const Vec3r y = preImage(map, xi);
          const Vec3r u = map.linear.transpose() * (vi - map.wallVelocity) + map.wallVelocity;
          const Real invRhoi = Real(1) / rhoi;
          const ForceQuery q{y.x(), y.y(), y.z(), u.x(), u.y(), u.z(), pi, rhoi, invRhoi};
          const std::uint32_t self = i;
          ForceSums sums = forceSums(k, records, q, workspace.mirrorList(m), workspace.mirrorCount[m]);
          addPairTerms(k, q, records[self], sums);
          a = map.linear * (sums.pressure - (viscosityCoeff * invRhoi) * sums.viscous);
        } else {
          // The mirror images themselves: position M x_j + o, velocity 2 w - v_j
          // (no slip) or w + M (v_j - w) (free slip), j's pressure and density.
          const Real invRhoi = Real(1) / rhoi;
          const ForceQuery q{xi.x(), xi.y(), xi.z(), vi.x(), vi.y(), vi.z(), pi, rhoi, invRhoi};
          ForceSums sums;
          auto visit = [&](std::uint32_t j) {
            const Vec3r x = map.apply(particles.position[j]);
            const Vec3r v = map.imageVelocity(particles.velocity[j], noSlip);
            const PairInput image{x.x(), x.y(), x.z(), particles.pressure[j],
                                  v.x(), v.y(), v.z(), particles.density[j]};
            addPairTerms(k, q, image, sums);
          };
          visit(i);  // i's own image (never behind its map)
          const std::uint32_t* list = workspace.mirrorList(m);
          std::for_each(list, list + workspace.mirrorCount[m], visit);
          a = sums.pressure - (viscosityCoeff * invRhoi) * sums.viscous;
        }
        if (hydrostaticImages)
          a += imageHydrostaticSum(k, map, xi, rhoi, records, i, workspace.mirrorList(m), workspace.mirrorCount[m],
                                   rho0g);
        total += a;
        // acting where the map's plane is (halfway to i's own image)
        if (map.boundary < boundaryCount)
          react(map.boundary, -(mass * a).cast<double>(), Real(0.5) * (xi + map.apply(xi)));
      }
      // Type I: SEED (11) f = D [(r0/r)^12 - (r0/r)^4] r / r^2, for r < r0.
      if (strength > 0 && sampleLists.count(i) > 0) {
        const auto repulsion = [&](std::uint32_t entry, Vec3r& a) {
          const Vec3r r = xi - samples[entry];
          const Real r2 = r.squaredNorm();
          if (r2 >= r02) return false;
          const Real q2 = r02 / std::max(r2, minR2);
          const Real q4 = q2 * q2, q12 = q4 * q4 * q4;
          a = (strength * (q12 - q4) / std::max(r2, minR2)) * r;
          return true;
        };
        // SEED (11) per solid (a few at most; more are merged into the last slot).
        constexpr int kSolids = 4;
        std::uint32_t solid[kSolids];
        Vec3r push[kSolids];
        Vec3r wallVelocity[kSolids];  // of a sample of each solid (zero at rest)
        Real scale[kSolids];
        int solids = 0;
        const auto slotOf = [&](std::uint32_t owner) {
          for (int k = 0; k < solids; ++k)
            if (solid[k] == owner) return k;
          return solids < kSolids ? solids : kSolids - 1;
        };
        Vec3r a;
        const std::uint32_t entryBegin = sampleLists.offsets[i], entryEnd = sampleLists.offsets[i + 1];
        for (std::uint32_t e = entryBegin; e < entryEnd; ++e)
          if (repulsion(e, a)) {
            const int k = slotOf(owners[e]);
            if (k == solids)
              solid[solids] = owners[e], push[solids] = Vec3r::Zero(),
              wallVelocity[solids] = boundary.sampleVelocity(sampleLists.indices[e]),
              scale[solids++] = 1;
            push[k] += a;
          }
        // Wedge contact limiter (not in the SEED): between two solids (a wedge of
        // floor and obstacle mesh) each pushes the particle deeper into the other's
        // r^-13 layer, where the explicit step is unstable: the bounce grew ~10x a
        // step to 60-300 m/s (production bunny and tower). There, each solid's push
        // in a step may stop and reflect the particle's approach to it (w, the
        // velocity from the other forces, along the push) but not throw it out
        // faster than it came or than contactSpeed: an elastic bounce at most.
        // Contact with one solid keeps SEED (11) as it is unless the approach is
        // faster than D = v_expected^2 can stop in time (fastApproach, blastApproach),
        // or the solid deforms: its samples are made afresh at each frame of its mesh
        // sequence, and a new sample can land next to a particle that sat between the
        // old ones (a cube growing in water, 1.2 cm spacing: the r^-12 push at 0.2 r0
        // threw a particle at rest out at 27 m/s, and the run stopped).
        if (timeStep > 0) {
          const Vec3r w = vi + timeStep * (c.acceleration[i] + total);
          for (int k = 0; k < solids; ++k) {
            const Real magnitude = push[k].norm();
            if (magnitude <= 0) continue;
            const Vec3r relative = w - wallVelocity[k];  // the approach to the solid, moving or not
            const Real approach = std::max(Real(0), -relative.dot(push[k]) / magnitude);
            if (solids == 1 && (approach <= fastApproach || approach > blastApproach) &&
                !boundary.resamples(solid[k]))
              continue;
            const Real allowed = (approach + std::max(approach, contactSpeed)) / timeStep;
            if (magnitude > allowed) scale[k] = allowed / magnitude;
          }
        }
        for (int k = 0; k < solids; ++k) total += scale[k] * push[k];
        for (std::uint32_t e = entryBegin; e < entryEnd; ++e) {
          const std::uint32_t owner = owners[e];
          if (owner < boundaryCount && repulsion(e, a))
            react(owner, -(mass * scale[slotOf(owner)] * a).cast<double>(), samples[e]);
        }
      }
      c.acceleration[i] += total;
    }
  });
  const std::vector<Vec3d> totals = reactions.totals();  // collective over ranks
  for (std::size_t b = 0; b < boundaryCount; ++b) {
    c.obstacleForce[b] = totals[reactions.index(0, b)];
    c.obstacleMoment[b] = totals[reactions.index(1, b)];
  }
}

void integrateContinuityDensity(StepContext& c, Workspace& workspace, Real dt, const std::vector<GuardedMove>& guarded) {
  Particles& particles = c.particles;
  PairInput* records = workspace.particles.data();
  // The ghosts' moves from their owners (the density rate reads them): their velocities,
  // and those of the guarded ones as their owners put them.
  const Vec3r* velocity = particles.velocity.data();
  if (c.partition) {
    workspace.moveRate.assign(particles.velocity.begin(), particles.velocity.end());
    for (const GuardedMove& move : guarded) workspace.moveRate[move.index] = move.displacementRate;
    c.partition->refreshGhosts(workspace.moveRate.data(), c.ownedCount());
    velocity = workspace.moveRate.data();
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3r& v = velocity[i];
      records[i].vx = v.x();
      records[i].vy = v.y();
      records[i].vz = v.z();
    }
  });
  if (!c.partition)
    for (const GuardedMove& move : guarded) {
      PairInput& record = records[move.index];
      record.vx = move.displacementRate.x();
      record.vy = move.displacementRate.y();
      record.vz = move.displacementRate.z();
    }
  computeDensityRate(c, workspace);
  const Real* rate = workspace.densityRate.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) particles.density[i] += dt * rate[i];
  });
}

Real integrateSymplecticEuler(StepContext& c, Real dt) {
  Particles& particles = c.particles;
  const std::vector<Vec3r>& acceleration = c.acceleration;
  const Real maxA2 = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, c.ownedCount(), 4096), Real(0),
      [&](const auto& range, Real m) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Vec3r& a = acceleration[i];
          m = std::max(m, a.squaredNorm());
          particles.velocity[i] += dt * a;                      // SEED (13)
          particles.position[i] += dt * particles.velocity[i];  // SEED (14)
        }
        return m;
      },
      [](Real a, Real b) { return std::max(a, b); });
  return std::sqrt(maxA2);
}

bool allowVectorPairLoops(bool allowed) {
#ifdef CASCADE_WCSPH_AVX2
  gAvx2Allowed.store(allowed);
  return wcsphUsesAvx2();
#else
  (void)allowed;
  return false;
#endif
}

bool allowAvx512PairLoops(bool allowed) {
#ifdef CASCADE_WCSPH_AVX2
  gAvx512Allowed.store(allowed);
  return wcsphUsesAvx2() && wcsphUsesAvx512Registers();
#else
  (void)allowed;
  return false;
#endif
}

} // namespace wcsph

void TimeStepWCSPH::advance(StepContext& c, Real dt) {
  const bool continuity = c.settings.solver.density == DensityEvolution::Continuity;
  auto start = Clock::now();
  if (continuity) {
    wcsph::gatherPairInputs(c, mWorkspace);
    c.timings.density += millisecondsSince(start);
    start = Clock::now();
    wcsph::collectMirrorNeighbors(c, mWorkspace);
    c.timings.boundary += millisecondsSince(start);
    start = Clock::now();
  } else {
    wcsph::computeFluidDensity(c, mWorkspace);  // with the mirror images' density (type II)
  }
  wcsph::computePressure(c, mWorkspace);
  c.timings.density += millisecondsSince(start);

  start = Clock::now();
  wcsph::computeFluidAcceleration(c, mWorkspace);
  c.timings.forces += millisecondsSince(start);

  start = Clock::now();
  wcsph::addBoundaryAcceleration(c, mWorkspace, dt);
  c.timings.boundary += millisecondsSince(start);

  start = Clock::now();
  wcsph::addVelocityFilter(c, mWorkspace);
  c.timings.forces += millisecondsSince(start);

  std::copy(c.obstacleForce.begin(), c.obstacleForce.end(), c.reportedObstacleForce.begin());
  start = Clock::now();
  c.maxAcceleration = wcsph::integrateSymplecticEuler(c, dt);
  c.timings.integrate += millisecondsSince(start);
}

void TimeStepWCSPH::finishStep(StepContext& c, Real dt, const std::vector<GuardedMove>& guarded) {
  if (c.settings.solver.density != DensityEvolution::Continuity) return;
  // The density moves with the new velocity, as the positions do (symplectic Euler:
  // with the old velocity the acoustic modes grow every step).
  const auto start = Clock::now();
  wcsph::integrateContinuityDensity(c, mWorkspace, dt, guarded);
  c.timings.density += millisecondsSince(start);
}

} // namespace cascade
