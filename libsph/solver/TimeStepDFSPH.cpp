#include "libsph/solver/TimeStepDFSPH.h"

#include "libsph/Errors.h"
#include "libsph/Kernels.h"
#include "libsph/boundary/BoundaryParticles.h"
#include "libsph/boundary/WallShearStress.h"
#include "libsph/solver/BoundConstrainedCG.h"
#include "libsph/solver/CoarseCorrection.h"
#include "libsph/solver/DomainPartition.h"
#include "libsph/solver/ParallelSum.h"
#include "libsph/solver/ReactionSums.h"
#include "libsph/solver/ReproducibleSum.h"

#if (defined(__x86_64__) || defined(__i386__)) && !defined(CASCADE_DOUBLE) && \
    (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define CASCADE_DFSPH_AVX2 1
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <istream>
#include <limits>
#include <ostream>

namespace cascade {

namespace {

using Clock = std::chrono::steady_clock;
double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

constexpr Real kDivergenceWarmStart = Real(0.5);  // divergence solve: half the last stiffness (SPlisHSPlasH)
// Constant-density solve: primal-dual active set with CG on the free set
// (BoundConstrainedCG.h). It stops when the mean predicted compression is below the
// tolerance and every particle's below a share of it (the per-particle bound is not
// diluted by depth): SolverSettings::particleToleranceShare, or by default these, the
// largest that hold a 200-layer column at rest with each preconditioner (the coarse
// correction converges the column's smooth modes that the bound otherwise has to force).
// Why: docs/dfsph-deep-water.md, "Constants" and "Two levels".
constexpr double kMaxResidualShare = 0.02, kTwoLevelResidualShare = 0.2;
// dt <= kStiffnessStepFactor h / sqrt(kappa_max): a CFL condition on the speed of a
// pressure signal, sqrt(kappa) (the wall layer's explicit spring; ibid.).
constexpr double kStiffnessStepFactor = 0.2;
// The viscous terms (prepare()) damp the pairs' relative velocities, integrated
// explicitly. On the rest lattice (cubic spline, h = 2 spacings) their fastest mode,
// neighbours moving apart and together along one axis, decays at the rate
// lambda = kDampingRate F / h^2 for a term on every pair (F = 10 nu) and at half of it
// for one on approaching pairs only (F = alpha h c_ref: half the pairs of that mode).
// dt <= 2 / lambda: no step amplifies it (a larger step reverses it, and grows it).
constexpr double kDampingRate = 5.70;

// Monaghan (1992) artificial viscosity Pi_ij = -alpha h c_ref (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2)
// for approaching pairs: the factor alpha h c_ref, with c_ref = 10 x the scene's expected
// speed, the speed of sound of the default WCSPH (DFSPH has none), so both solvers get the
// same numerical viscosity.
Real artificialViscosityFactor(const SolverSettings& solver, const DerivedConstants& constants) {
  return solver.artificialViscosity * constants.supportRadius * Real(10) * constants.expectedSpeed;
}
// The solve stops at this share of densityTolerance: the next step's compression exceeds
// the solve's linear prediction by up to 4 % (ibid.).
constexpr double kDensityToleranceMargin = 0.9;
// Largest share of an existing compression (overlap, impact) removed in one step, so
// that particles part over several steps instead of at error * spacing / dt (ibid.).
constexpr Real kMaxErrorPerStep = Real(0.01);
constexpr std::uint32_t kMinDivergenceNeighbors = 20;  // B&K 2017: no divergence solve at the surface
constexpr std::uint32_t kNotInLayer = ~std::uint32_t(0);

template <typename T>
void keepIf(std::vector<T>& values, const std::vector<char>& remove) {
  if (values.size() != remove.size()) return;
  std::size_t out = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!remove[i]) values[out++] = values[i];
  values.resize(out);
}

template <typename T>
void writeVector(std::ostream& out, const std::vector<T>& values) {
  const std::uint64_t n = values.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof(n));
  out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(n * sizeof(T)));
}

template <typename T>
void readVector(std::istream& in, std::vector<T>& values) {
  std::uint64_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof(n));
  if (!in || n != values.size()) throw InputError("checkpoint: DFSPH warm-start data does not match the particles");
  in.read(reinterpret_cast<char*>(values.data()), std::streamsize(n * sizeof(T)));
  if (!in) throw InputError("checkpoint: truncated DFSPH warm-start data");
}

/// The sums of one particle's fluid pairs in prepare() (see there).
struct PairSums {
  Real density = 0, gradientSquares = 0, rate = 0;
  Vec3r gradientSum = Vec3r::Zero(), viscous = Vec3r::Zero();
  std::uint32_t stored = 0, inside = 0;  // pair terms written; neighbours strictly inside the support
};

/// Constants of the pair pass.
struct PairConstants {
  Real supportRadius2, inverseSupport, valueCoeff, gradientCoeff, volume, epsilon2, viscosity, artificial;
};

/// The mirror images of one source j that a layer particle i sees: sum over them of
/// L^T G (the coefficient of v_j in i's density rate, L the image's velocity map) and
/// of Q G (j's own mirror of i has the gradient -Q G: Q x_i - x_j + t = -(x_j - L x_i)).
struct ImageSums {
  std::uint32_t source;
  Vec3r velocityGradient, reflectedGradient;
};

std::vector<ImageSums>& imageScratch() {
  thread_local std::vector<ImageSums> scratch;
  return scratch;
}

/// The part of the density solve's diagonal that the mirrors add through i's
/// neighbours: kappa_i moves each neighbour j by dt (g_ij + sum Q G) (the pair and
/// j's images of i), which changes i's density rate by -(g_ij + sum L^T G) . that
/// (the pair and i's images of j). Returns sum_j (g_ij + A_j) . (g_ij + B_j) - |g_ij|^2
/// (|g_ij|^2 is already in the fluid sum), g_ij = V grad W(x_i - x_j). The sources go
/// in index order, or, with `ids` (over MPI ranks), in id order: the same on every rank.
template <typename Kernel>
Real imageCouplings(std::vector<ImageSums>& images, const Vec3r& xi, const std::vector<Vec3r>& position,
                    const Kernel& kernel, Real volume, Real supportRadius2, const ParticleId* ids) {
  if (ids)
    std::stable_sort(images.begin(), images.end(),
                     [ids](const ImageSums& a, const ImageSums& b) { return ids[a.source] < ids[b.source]; });
  else
    std::sort(images.begin(), images.end(), [](const ImageSums& a, const ImageSums& b) { return a.source < b.source; });
  Real sum = 0;
  for (std::size_t k = 0; k < images.size();) {
    const std::uint32_t j = images[k].source;
    Vec3r velocityGradient = Vec3r::Zero(), reflectedGradient = Vec3r::Zero();
    for (; k < images.size() && images[k].source == j; ++k) {
      velocityGradient += images[k].velocityGradient;
      reflectedGradient += images[k].reflectedGradient;
    }
    const Vec3r r = xi - position[j];
    const Vec3r pair = r.squaredNorm() < supportRadius2 ? Vec3r(volume * kernel.gradient(r)) : Vec3r::Zero();
    sum += pair.dot(reflectedGradient) + velocityGradient.dot(pair + reflectedGradient);
  }
  return sum;
}

// Bytes of one pair record (TimeStepDFSPH::PairTerm): the neighbour's index, then V grad W_ij
// as three halves. The AVX2/F16C loops below write and read the records by this stride.
constexpr std::size_t kPairBytes = 10;

#ifdef CASCADE_DFSPH_AVX2
#define CASCADE_DFSPH_TARGET __attribute__((target("avx2,fma,f16c")))

/// The eight lanes of v added pairwise (once per particle: no shuffles needed).
CASCADE_DFSPH_TARGET inline float horizontalSum(__m256 v) {
  alignas(32) float lane[8];
  _mm256_store_ps(lane, v);
  return ((lane[0] + lane[1]) + (lane[2] + lane[3])) + ((lane[4] + lane[5]) + (lane[6] + lane[7]));
}

/// prepare()'s pair loop for eight neighbours at a time (the same terms as the scalar
/// loop; a neighbour on the support's edge or on top of i is stored with a zero
/// gradient instead of dropped, so rows stay in order and need no compaction). The
/// gradients are rounded to halves first (F16C, round to nearest even: halfFromFloat).
CASCADE_DFSPH_TARGET void fluidPairsAvx2(const Vec3r& xi, const Vec3r& vi, const Vec3r* position,
                                         const Vec3r* velocity, const std::uint32_t* neighbors, std::uint32_t count,
                                         const PairConstants& k, void* pairsOut, PairSums& sums) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 pxi = _mm256_set1_ps(xi.x()), pyi = _mm256_set1_ps(xi.y()), pzi = _mm256_set1_ps(xi.z());
  const __m256 vxi = _mm256_set1_ps(vi.x()), vyi = _mm256_set1_ps(vi.y()), vzi = _mm256_set1_ps(vi.z());
  const __m256 h2 = _mm256_set1_ps(k.supportRadius2), invH = _mm256_set1_ps(k.inverseSupport);
  const __m256 eps2 = _mm256_set1_ps(k.epsilon2), volume = _mm256_set1_ps(k.volume);
  const __m256 valueCoeff = _mm256_set1_ps(k.valueCoeff), gradientCoeff = _mm256_set1_ps(k.gradientCoeff);
  const __m256 viscosity = _mm256_set1_ps(Real(10) * k.viscosity), artificial = _mm256_set1_ps(k.artificial);
  __m256 density = zero, squares = zero, rate = zero, gx = zero, gy = zero, gz = zero, ax = zero, ay = zero, az = zero;
  const float* pos = position[0].data();
  const float* vel = velocity[0].data();
  unsigned char* out = static_cast<unsigned char*>(pairsOut);
  std::uint32_t inside = 0;
  for (std::uint32_t base = 0; base < count; base += 8) {
    const std::uint32_t lanes = std::min<std::uint32_t>(8, count - base);
    alignas(32) std::int32_t index[8];
    for (std::uint32_t l = 0; l < 8; ++l) index[l] = static_cast<std::int32_t>(neighbors[base + (l < lanes ? l : 0)]);
    const __m256i j = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(index));
    const __m256i j3 = _mm256_add_epi32(j, _mm256_add_epi32(j, j));
    const __m256 rx = _mm256_sub_ps(pxi, _mm256_i32gather_ps(pos, j3, 4));
    const __m256 ry = _mm256_sub_ps(pyi, _mm256_i32gather_ps(pos + 1, j3, 4));
    const __m256 rz = _mm256_sub_ps(pzi, _mm256_i32gather_ps(pos + 2, j3, 4));
    const __m256 r2 = _mm256_fmadd_ps(rx, rx, _mm256_fmadd_ps(ry, ry, _mm256_mul_ps(rz, rz)));
    const __m256 laneOk = _mm256_castsi256_ps(
        _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(lanes)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
    const __m256 valid =
        _mm256_and_ps(laneOk, _mm256_and_ps(_mm256_cmp_ps(r2, h2, _CMP_LT_OQ), _mm256_cmp_ps(r2, zero, _CMP_GT_OQ)));
    inside += static_cast<std::uint32_t>(__builtin_popcount(_mm256_movemask_ps(valid)));
    const __m256 safe2 = _mm256_blendv_ps(h2, r2, valid);  // invalid lanes: any positive distance
    const __m256 length = _mm256_sqrt_ps(safe2);
    const __m256 q = _mm256_mul_ps(length, invH), d = _mm256_sub_ps(one, q);
    const __m256 inner = _mm256_cmp_ps(q, _mm256_set1_ps(0.5f), _CMP_LE_OQ);
    // W: 6 q^2 (q - 1) + 1 inside q <= 1/2, 2 d^3 outside; W': q (3 q - 2), -d^2.
    const __m256 valueInner = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_set1_ps(6.0f), _mm256_mul_ps(q, q)), _mm256_sub_ps(q, one), one);
    const __m256 valueOuter = _mm256_mul_ps(_mm256_set1_ps(2.0f), _mm256_mul_ps(d, _mm256_mul_ps(d, d)));
    const __m256 value = _mm256_mul_ps(valueCoeff, _mm256_blendv_ps(valueOuter, valueInner, inner));
    const __m256 slopeInner = _mm256_mul_ps(q, _mm256_fmsub_ps(_mm256_set1_ps(3.0f), q, _mm256_set1_ps(2.0f)));
    const __m256 slopeOuter = _mm256_sub_ps(zero, _mm256_mul_ps(d, d));
    const __m256 slope = _mm256_mul_ps(gradientCoeff, _mm256_blendv_ps(slopeOuter, slopeInner, inner));
    const __m256 shifted = _mm256_add_ps(safe2, eps2);
    const __m256 inverse = _mm256_div_ps(one, _mm256_mul_ps(length, shifted));
    density = _mm256_add_ps(density, _mm256_and_ps(valid, _mm256_mul_ps(volume, value)));
    const __m256 scale = _mm256_and_ps(valid, _mm256_mul_ps(_mm256_mul_ps(volume, slope), _mm256_mul_ps(shifted, inverse)));
    // V grad W_ij, rounded to halves: the values stored and used everywhere below.
    const __m128i hx = _mm256_cvtps_ph(_mm256_mul_ps(scale, rx), 0), hy = _mm256_cvtps_ph(_mm256_mul_ps(scale, ry), 0),
                  hz = _mm256_cvtps_ph(_mm256_mul_ps(scale, rz), 0);
    const __m256 ggx = _mm256_cvtph_ps(hx), ggy = _mm256_cvtph_ps(hy), ggz = _mm256_cvtph_ps(hz);
    // Pair terms {j, 3 halves}: ten-byte records.
    {
      alignas(16) std::uint16_t halves[3][8];
      _mm_store_si128(reinterpret_cast<__m128i*>(halves[0]), hx);
      _mm_store_si128(reinterpret_cast<__m128i*>(halves[1]), hy);
      _mm_store_si128(reinterpret_cast<__m128i*>(halves[2]), hz);
      for (std::uint32_t l = 0; l < lanes; ++l) {
        unsigned char* record = out + kPairBytes * std::size_t(base + l);
        std::memcpy(record, &index[l], 4);
        const std::uint16_t g[3] = {halves[0][l], halves[1][l], halves[2][l]};
        std::memcpy(record + 4, g, 6);
      }
    }
    gx = _mm256_add_ps(gx, ggx);
    gy = _mm256_add_ps(gy, ggy);
    gz = _mm256_add_ps(gz, ggz);
    squares = _mm256_fmadd_ps(ggx, ggx, _mm256_fmadd_ps(ggy, ggy, _mm256_fmadd_ps(ggz, ggz, squares)));
    const __m256 vxj = _mm256_i32gather_ps(vel, j3, 4);
    const __m256 vyj = _mm256_i32gather_ps(vel + 1, j3, 4);
    const __m256 vzj = _mm256_i32gather_ps(vel + 2, j3, 4);
    rate = _mm256_fmadd_ps(vxj, ggx, _mm256_fmadd_ps(vyj, ggy, _mm256_fmadd_ps(vzj, ggz, rate)));
    const __m256 vx = _mm256_fmadd_ps(_mm256_sub_ps(vxi, vxj), rx,
                                      _mm256_fmadd_ps(_mm256_sub_ps(vyi, vyj), ry, _mm256_mul_ps(_mm256_sub_ps(vzi, vzj), rz)));
    const __m256 factor = _mm256_add_ps(viscosity, _mm256_and_ps(_mm256_cmp_ps(vx, zero, _CMP_LT_OQ), artificial));
    const __m256 viscous = _mm256_mul_ps(_mm256_mul_ps(factor, vx), _mm256_mul_ps(length, inverse));  // 0 where scale is
    ax = _mm256_fmadd_ps(viscous, ggx, ax);
    ay = _mm256_fmadd_ps(viscous, ggy, ay);
    az = _mm256_fmadd_ps(viscous, ggz, az);
  }
  sums.density += horizontalSum(density);
  sums.gradientSquares += horizontalSum(squares);
  sums.rate += horizontalSum(rate);
  sums.gradientSum += Vec3r(horizontalSum(gx), horizontalSum(gy), horizontalSum(gz));
  sums.viscous += Vec3r(horizontalSum(ax), horizontalSum(ay), horizontalSum(az));
  sums.stored = count;
  sums.inside = inside;
}

bool haveAvx2() {
  static const bool supported =
      __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("f16c");
  return supported;
}

/// A pair record's neighbour index.
inline std::uint32_t recordNeighbor(const unsigned char* record) {
  std::uint32_t j;
  std::memcpy(&j, record, 4);
  return j;
}
/// A pair record's gradient widened by F16C in one instruction: the three halves are read
/// with the next record's first two bytes (the rows are padded by one record), so the
/// fourth lane holds no value and every user drops it.
CASCADE_DFSPH_TARGET inline __m128 recordGradient(const unsigned char* record) {
  return _mm_cvtph_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(record + 4)));
}

/// The operator products' pair loops with F16C: sum over a row's records of
/// lane(j) * g (four lanes, the fourth dropped).
template <typename Lane>
CASCADE_DFSPH_TARGET __m128 rowSumF16c(const void* pairs, std::uint32_t count, const Lane& lane) {
  const unsigned char* record = static_cast<const unsigned char*>(pairs);
  __m128 sum = _mm_setzero_ps();
  for (std::uint32_t k = 0; k < count; ++k, record += kPairBytes)
    sum = _mm_fmadd_ps(lane(recordNeighbor(record)), recordGradient(record), sum);
  return sum;
}
/// velocityChange(): s_j in every lane.
struct StiffnessLane {
  const Real* step;
  CASCADE_DFSPH_TARGET __m128 operator()(std::uint32_t j) const { return _mm_set1_ps(step[j]); }
};
/// divergence(): v_j (x, y as 8 unaligned bytes, then z; the fourth lane 0).
struct VelocityLane {
  const Vec3r* velocity;
  CASCADE_DFSPH_TARGET __m128 operator()(std::uint32_t j) const {
    const float* v = velocity[j].data();
    return _mm_movelh_ps(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(v))), _mm_load_ss(v + 2));
  }
};
CASCADE_DFSPH_TARGET Vec3r rowChangeF16c(const void* pairs, std::uint32_t count, const Real* step) {
  alignas(16) float lane[4];
  _mm_store_ps(lane, rowSumF16c(pairs, count, StiffnessLane{step}));
  return Vec3r(lane[0], lane[1], lane[2]);
}
CASCADE_DFSPH_TARGET Real rowDivergenceF16c(const void* pairs, std::uint32_t count, const Vec3r* velocity) {
  alignas(16) float lane[4];
  _mm_store_ps(lane, rowSumF16c(pairs, count, VelocityLane{velocity}));
  return (lane[0] + lane[1]) + lane[2];
}
/// The coarse operator's rows (TimeStepDFSPH::solveOneSided): a row's records as
/// (neighbour, gradient) coefficients.
CASCADE_DFSPH_TARGET void appendRowF16c(const void* pairs, std::uint32_t count,
                                        std::vector<CoarseCorrection::Coefficient>& row) {
  const unsigned char* record = static_cast<const unsigned char*>(pairs);
  const std::size_t first = row.size();
  row.resize(first + count);
  CoarseCorrection::Coefficient* out = row.data() + first;
  for (std::uint32_t k = 0; k < count; ++k, record += kPairBytes) {
    alignas(16) float g[4];
    _mm_store_ps(g, recordGradient(record));
    out[k] = {recordNeighbor(record), Vec3r(g[0], g[1], g[2])};
  }
}
#else
bool haveAvx2() { return false; }
#endif

} // namespace

TimeStepNeeds TimeStepDFSPH::needs(const SimulationSettings& settings, const DerivedConstants& constants) const {
  TimeStepNeeds needs;
  needs.speedOfSoundInCfl = false;  // incompressible: CFL on the velocity only
  needs.mirrorParticles = true;     // the boundary model: type II mirror particles (SEED section 2.2)
  // Force limit dt <= 0.06 sqrt(h / a) with a the non-pressure accelerations. Measured:
  // 0.12 saves 19 % of the CPU time of the 59 k dam break's first 0.4 s, but the 4-layer
  // hydrostatic slab then holds only 0.1 % average compression (0.047 % at 0.06) and moves
  // at 0.03 m/s RMS.
  // Only gravity counts as a (given) force there (without coupled bodies: advance()); the
  // viscous terms are damping, whose step limit is their rate, not their size (a 59.5 k dam
  // break's artificial viscosity reached 70 g at the impact and cut the step to 0.7 ms;
  // docs/dfsph-deep-water.md, "The time step").
  needs.forceStepFactor = Real(0.06);
  needs.maxCflFactor = kDfsphMaxCfl;
  const double h = constants.supportRadius;
  const double physical = 10.0 * double(settings.fluid.viscosity) / double(settings.fluid.restDensity);
  const double artificial = double(artificialViscosityFactor(settings.solver, constants));
  const double rate = kDampingRate * (physical + 0.5 * artificial) / (h * h);  // lambda
  if (rate > 0) needs.dampingStep = 2.0 / rate;
  return needs;
}

void TimeStepDFSPH::resize(std::size_t count) {
  mDensityKappa.resize(count, Real(0));
  mDivergenceKappa.resize(count, Real(0));
  mWallAge.resize(count, Real(0));
}

void TimeStepDFSPH::packState(std::size_t i, Real* out) const {
  out[0] = mDensityKappa[i];
  out[1] = mDivergenceKappa[i];
  out[2] = mWallAge[i];
}

void TimeStepDFSPH::unpackState(std::size_t i, const Real* in) {
  mDensityKappa[i] = in[0];
  mDivergenceKappa[i] = in[1];
  mWallAge[i] = in[2];
}

void TimeStepDFSPH::permute(const std::vector<std::size_t>& order) {
  for (std::vector<Real>* values : {&mDensityKappa, &mDivergenceKappa, &mWallAge}) {
    if (values->size() != order.size()) continue;
    std::vector<Real> permuted(order.size());
    for (std::size_t k = 0; k < order.size(); ++k) permuted[k] = (*values)[order[k]];
    values->swap(permuted);
  }
}

void TimeStepDFSPH::removeIf(const std::vector<char>& remove) {
  keepIf(mDensityKappa, remove);
  keepIf(mDivergenceKappa, remove);
  keepIf(mWallAge, remove);
}

void TimeStepDFSPH::save(std::ostream& out) const {
  writeVector(out, mDensityKappa);
  writeVector(out, mDivergenceKappa);
  out.write(reinterpret_cast<const char*>(&mRegularStep), sizeof(mRegularStep));
  writeVector(out, mWallAge);
}

void TimeStepDFSPH::restore(std::istream& in) {
  readVector(in, mDensityKappa);
  readVector(in, mDivergenceKappa);
  in.read(reinterpret_cast<char*>(&mRegularStep), sizeof(mRegularStep));
  if (!in) throw InputError("checkpoint: truncated DFSPH state");
  // Boundary-layer ages (wall shear); a checkpoint written before they existed ends here.
  if (in.peek() == std::char_traits<char>::eof()) {
    in.clear();
    std::fill(mWallAge.begin(), mWallAge.end(), Real(0));
  } else {
    readVector(in, mWallAge);
  }
}

/// Step 1: densities, kernel gradients (kept per pair for the solves), factors;
/// the mirror (type II) particles of the boundary layer as ghost pairs.
void TimeStepDFSPH::prepare(StepContext& c) {
  Particles& particles = c.particles;
  const std::size_t n = particles.size();
  const Real h = c.constants.supportRadius, h2 = h * h;
  const KernelCubicSpline kernel(h);
  const BoundaryParticles& boundary = c.boundary;

  if (mLatticeSupport != h) {
    // Rest volume: the initial lattice of the fluid spacing is at rest density.
    const Real s = c.settings.fluid.spacing;
    const int reach = static_cast<int>(std::ceil(h / s));
    double sum = 0, gradientSum = 0;
    for (int z = -reach; z <= reach; ++z)
      for (int y = -reach; y <= reach; ++y)
        for (int x = -reach; x <= reach; ++x) {
          const Vec3r r = s * Vec3r(Real(x), Real(y), Real(z));
          sum += kernel.value(r.norm());
          gradientSum += kernel.gradient(r).squaredNorm();
        }
    mRestVolume = static_cast<Real>(1.0 / sum);
    // alpha's denominator for a full lattice neighbourhood; 1e-4 of it is the floor below which
    // a particle (nearly alone) gets alpha = 0 instead of an unbounded stiffness.
    mFactorFloor = static_cast<Real>(1e-4 * gradientSum * double(mRestVolume) * double(mRestVolume));
    mLatticeSupport = h;
  }
  const Real volume = mRestVolume;
  const NeighborLists& nl = c.neighbors;
  const std::vector<MirrorMap>& maps = boundary.mirrors();
  const bool noSlip = c.settings.boundary.slip == MirrorSlip::NoSlip;

  // Ghosts: for each layer particle, the mirror images (of itself and its neighbours) within h.
  const std::vector<std::uint32_t>& layer = boundary.layer();
  const bool mirrors = boundary.mirrorOffsets().size() == n + 1 && !maps.empty();
  mLayerIndex.assign(n, kNotInLayer);
  mWallRate.clear();
  mGhostOffsets.assign(1, 0);
  mGhostSource.clear();
  mGhostMap.clear();
  mGhostGradient.clear();
  mGhostVelocityGradient.clear();
  if (mirrors) {
    const std::vector<std::uint32_t>& mapOffsets = boundary.mirrorOffsets();
    auto forEachGhost = [&](std::uint32_t i, auto&& visit) {
      const Vec3r xi = particles.position[i];
      for (std::uint32_t m = mapOffsets[i]; m < mapOffsets[i + 1]; ++m) {
        const MirrorMap& map = maps[m];
        auto image = [&](std::uint32_t j) {
          if (map.behind(xi, particles.position[j])) return;
          const Vec3r r = xi - map.apply(particles.position[j]);
          if (r.squaredNorm() < h2) visit(j, m, r);
        };
        image(i);
        for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j) image(*j);
      }
    };
    mGhostOffsets.assign(layer.size() + 1, 0);
    tbb::parallel_for(std::size_t(0), layer.size(), [&](std::size_t k) {
      std::uint32_t count = 0;
      forEachGhost(layer[k], [&](std::uint32_t, std::uint32_t, const Vec3r&) { ++count; });
      mGhostOffsets[k + 1] = count;
      mLayerIndex[layer[k]] = static_cast<std::uint32_t>(k);
    });
    for (std::size_t k = 0; k < layer.size(); ++k) mGhostOffsets[k + 1] += mGhostOffsets[k];
    const std::size_t total = mGhostOffsets.back();
    mGhostSource.resize(total);
    mGhostMap.resize(total);
    mGhostGradient.resize(total);
    mGhostVelocityGradient.resize(total);
    mGhostValue.resize(total);
    mGhostOffset.resize(total);
    mGhostViscous.resize(total);
    mWallRate.assign(layer.size(), Real(0));
    tbb::parallel_for(std::size_t(0), layer.size(), [&](std::size_t k) {
      std::uint32_t g = mGhostOffsets[k];
      Real wallRate = 0;
      forEachGhost(layer[k], [&](std::uint32_t j, std::uint32_t m, const Vec3r& r) {
        mGhostSource[g] = j;
        mGhostMap[g] = m;
        const Vec3r gradient = volume * kernel.gradient(r);
        mGhostGradient[g] = gradient;
        // The image's velocity is L v_j (L = -I for no slip): (L v_j) . G = v_j . (L^T G).
        mGhostVelocityGradient[g] =
            noSlip && !maps[m].symmetry ? Vec3r(-gradient) : Vec3r(maps[m].linear.transpose() * gradient);
        mGhostValue[g] = volume * kernel.value(r.norm());
        mGhostOffset[g] = r;
        // A moving wall: the image's velocity is L v_j + w_g (MirrorMap::imageVelocity).
        const MirrorMap& map = maps[m];
        if (!map.wallVelocity.isZero()) wallRate += map.imageVelocity(Vec3r::Zero(), noSlip).dot(gradient);
        ++g;
      });
      mWallRate[k] = wallRate;
    });
  }

  // Pair terms: the neighbours strictly inside the support (grad W != 0), packed at the
  // start of each neighbour-list row; the rest of the row is unused.
  mPairs.resize(mPairOffsets[nl.size()] + 1);  // + 1: the F16C loops read two bytes past a row's last record
  mPairCount.resize(n);
  mGradientSum.resize(n);
  mFactor.resize(n);
  mDensityRatio.resize(n);
  mNeighborCount.resize(n);
  mRate.resize(n);
  c.acceleration.resize(n);
  const Real selfValue = kernel.value(0);
  const Real restDensity = c.settings.fluid.restDensity;
  const Real floor = mFactorFloor;
  const std::vector<Vec3r>& velocity = particles.velocity;
  const SolverSettings& solver = c.settings.solver;
  const Vec3r gravity = solver.gravity;
  const Real nu = c.settings.fluid.viscosity / c.settings.fluid.restDensity;
  const Real epsilon2 = Real(0.01) * h2;
  const Real artificial = artificialViscosityFactor(solver, c.constants);
  // Viscous factor per pair: standard SPH viscosity (Morris 1997 form, as in SPlisHSPlasH)
  // 2 (d + 2) nu = 10 nu, plus the artificial term for approaching pairs.
  auto viscousFactor = [&](Real vx) { return Real(10) * nu + (vx < 0 ? artificial : Real(0)); };
  std::vector<Vec3r>& acceleration = c.acceleration;
  static_assert(sizeof(PairTerm) == kPairBytes, "pair terms are 10-byte records, as the AVX2/F16C loops step");
  mPosition = particles.position.data();
  mSupportRadius = h;
  const bool avx2 = haveAvx2() && std::getenv("CASCADE_NO_AVX2") == nullptr;
  mHalfInstructions = avx2;
  const PairConstants pairConstants{h2, kernel.inverseSupport, kernel.valueCoeff, kernel.gradientCoeff, volume, epsilon2,
                                    nu, artificial};
  // The owned particles (a halo copy takes its values from its owner).
  forEachIndex(mOwned, [&](std::size_t i) {
    const Vec3r xi = particles.position[i], vi = velocity[i];
    Real density = volume * selfValue;
    Vec3r gradientSum = Vec3r::Zero();
    Real gradientSquares = 0;
    Real rate = 0;  // sum_j c_ij v_j . (x_i - x_j)
    Vec3r viscous = Vec3r::Zero();
    PairTerm* pair = mPairs.data() + mPairOffsets[i];
    std::uint32_t count = 0, stored = 0;
#ifdef CASCADE_DFSPH_AVX2
    if (avx2) {
      PairSums sums;
      fluidPairsAvx2(xi, vi, particles.position.data(), velocity.data(), nl.indices.data() + nl.offsets[i],
                     nl.count(i), pairConstants, pair, sums);
      density += sums.density;
      gradientSum = sums.gradientSum;
      gradientSquares = sums.gradientSquares;
      rate = sums.rate;
      viscous = sums.viscous;
      stored = sums.stored;
      count = sums.inside;
    }
#endif
    for (std::uint32_t k = avx2 ? nl.endOffset(i) : nl.offsets[i]; k < nl.endOffset(i); ++k) {
      const std::uint32_t j = nl.indices[k];
      const Vec3r r = xi - particles.position[j];
      const Real r2 = r.squaredNorm();
      if (!(r2 < h2) || !(r2 > Real(0))) continue;
      // Cubic spline W and grad W = W'(|r|) r / |r| (both branches, then a select), with
      // one square root and one division for 1 / |r| and 1 / (|r|^2 + 0.01 h^2).
      const Real length = std::sqrt(r2), q = length * kernel.inverseSupport, d = Real(1) - q;
      const bool inner = q <= Real(0.5);
      const Real value = kernel.valueCoeff * (inner ? Real(6) * q * q * (q - Real(1)) + Real(1) : Real(2) * d * d * d);
      const Real slope = kernel.gradientCoeff * (inner ? q * (Real(3) * q - Real(2)) : -d * d);
      const Real shifted = r2 + epsilon2;
      const Real inverse = Real(1) / (length * shifted);
      density += volume * value;
      const Real scale = volume * slope * shifted * inverse;  // V grad W_ij = scale (x_i - x_j)
      PairTerm& term = pair[stored++];
      term.neighbor = j;
      for (int a = 0; a < 3; ++a) term.gradient[a] = halfFromFloat(scale * r[a]);
      const Vec3r g = term.value();  // the rounded gradient, as the AVX2 loop and the solves take it
      ++count;
      gradientSum += g;
      gradientSquares += g.squaredNorm();
      const Vec3r& vj = velocity[j];
      rate += vj.dot(g);
      // a_i += sum_j F (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2) V grad W_ij (rest volume V: the
      // density is held at rho_0; a free-surface particle's summed density is only a kernel deficit)
      const Real vx = (vi - vj).dot(r);
      viscous += (viscousFactor(vx) * vx * length * inverse) * g;
    }
    mPairCount[i] = stored;
    Real denominator;
    const std::uint32_t l = mLayerIndex[i];
    if (l == kNotInLayer) {
      denominator = gradientSum.squaredNorm() + gradientSquares;  // B&K 2017 eq. 10
    } else {
      // With mirrors: i's own images move with it (their pair takes 2 kappa_i and
      // the mirrored velocity change), so the diagonal of the density change per
      // kappa_i is g^.g~ + sum_fluid |g|^2 - sum_self (L g~) . G_ii' with g~ the
      // velocity-change direction (own images counted twice), plus what reaches i
      // back through each neighbour's images (imageCouplings).
      Vec3r change = gradientSum;
      std::vector<ImageSums>& images = imageScratch();
      images.clear();
      for (std::uint32_t g = mGhostOffsets[l]; g < mGhostOffsets[l + 1]; ++g) {
        const Vec3r& G = mGhostGradient[g];
        const std::uint32_t j = mGhostSource[g];
        density += mGhostValue[g];
        gradientSum += G;
        if (j == i) {
          change += Real(2) * G;
        } else {
          change += G;
          // j's own mirror of i (the same map, an involution) has the gradient -Q G.
          images.push_back(ImageSums{j, mGhostVelocityGradient[g], maps[mGhostMap[g]].linear * G});
        }
        rate += velocity[j].dot(mGhostVelocityGradient[g]);
        // Mirror particles in the viscous terms with the image's velocity (L v_j; -v_j for no
        // slip): a no-slip wall exerts friction and any wall damps approaching motion.
        const Vec3r& x = mGhostOffset[g];
        const MirrorMap& map = maps[mGhostMap[g]];
        const Vec3r image = map.imageVelocity(velocity[j], noSlip);
        const Real vx = (vi - image).dot(x);
        mGhostViscous[g] = (viscousFactor(vx) * vx / (x.squaredNorm() + epsilon2)) * G;  // a wall force too
        viscous += mGhostViscous[g];
      }
      rate += mWallRate[l];
      denominator = gradientSum.dot(change) + gradientSquares + imageCouplings(images, xi, particles.position, kernel, volume, h2,
                                                                           c.partition ? particles.id.data() : nullptr);
      for (std::uint32_t g = mGhostOffsets[l]; g < mGhostOffsets[l + 1]; ++g)
        if (mGhostSource[g] == i) {
          const MirrorMap& map = maps[mGhostMap[g]];
          const Vec3r mirroredChange = noSlip && !map.symmetry ? Vec3r(-change) : Vec3r(map.linear * change);
          denominator -= mirroredChange.dot(mGhostGradient[g]);
        }
      count += mGhostOffsets[l + 1] - mGhostOffsets[l];
    }
    mGradientSum[i] = gradientSum;  // over fluid and mirror neighbours
    mRate[i] = vi.dot(gradientSum) - rate;  // D(rho_i/rho_0)/Dt of the step's initial velocities
    acceleration[i] = gravity + viscous;
    mFactor[i] = denominator > floor ? Real(1) / denominator : Real(0);
    mDensityRatio[i] = density;
    mNeighborCount[i] = count;
    particles.density[i] = restDensity * density;
  });
}

/// Wall shear of the unresolved laminar boundary layer (WallShearStress.h): the slip
/// velocity of each particle within one spacing of a wall (single reflections that
/// are not symmetry planes; walls at rest) decays by laminarWallShearDecay over the
/// step, with the age of its boundary layer = the time it has been that close
/// (0 when it arrives; the fluid at rest on the floor starts its layer at release).
void TimeStepDFSPH::applyWallShear(StepContext& c, Real dt) {
  const std::size_t n = c.particles.size();
  const Real nu = c.settings.fluid.viscosity / c.settings.fluid.restDensity;
  const Real spacing = c.settings.fluid.spacing;
  const std::vector<MirrorMap>& maps = c.boundary.mirrors();
  const std::vector<std::uint32_t>& mapOffsets = c.boundary.mirrorOffsets();
  const bool mirrors = mapOffsets.size() == n + 1 && !maps.empty();
  std::vector<Vec3r>& velocity = c.particles.velocity;
  forEachIndex(n, [&](std::size_t i) {
    bool touching = false;
    if (mirrors && mLayerIndex[i] != kNotInLayer) {
      const Vec3r xi = c.particles.position[i];
      const Real decay = laminarWallShearDecay(nu, spacing, double(mWallAge[i]), double(dt));
      for (std::uint32_t m = mapOffsets[i]; m < mapOffsets[i + 1]; ++m) {
        const MirrorMap& map = maps[m];
        if (map.symmetry || std::abs(map.linear.trace() - Real(1)) > Real(1e-3)) continue;
        const Vec3r toImage = xi - map.apply(xi);  // 2 d n
        const Real twice = toImage.norm();
        if (!(twice > Real(0)) || Real(0.5) * twice >= spacing) continue;
        const Vec3r normal = toImage / twice;
        const Vec3r relative = velocity[i] - map.wallVelocity;  // slip over the wall, moving or not
        const Real normalSpeed = relative.dot(normal);
        velocity[i] = map.wallVelocity + normalSpeed * normal + decay * (relative - normalSpeed * normal);
        touching = true;
      }
    }
    mWallAge[i] = touching ? mWallAge[i] + dt : Real(0);
  });
}

/// Velocity update of B&K 2017 alg. 2/3 for the stiffness increments `step`, a mirror
/// particle taking the increment of its source:
/// v_i -= dt sum_j V (s_i + s_j) grad W_ij = dt (s_i G_i + sum_j s_j V grad W_ij)
/// over fluid and mirror neighbours (G_i = sum_j V grad W_ij); kappa += step.
void TimeStepDFSPH::applyStep(std::vector<Vec3r>& velocity, std::vector<Real>& kappa, Real dt) {
  shareWithHalo(mKappaStep.data());  // the neighbours' increments, from their owners
  const Real* step = mKappaStep.data();
  forEachIndex(mOwned, [&](std::size_t i) {
    velocity[i] -= dt * velocityChange(step, i);
    kappa[i] += step[i];
  });
  shareWithHalo(velocity.data());  // and their new velocities, for the next rates
}

void TimeStepDFSPH::shareWithHalo(Real* values) const {
  if (mPartition) mPartition->refreshGhosts(values, mOwned);
}

void TimeStepDFSPH::shareWithHalo(Vec3r* values) const {
  if (mPartition) mPartition->refreshGhosts(values, mOwned);
}

double TimeStepDFSPH::overRanks(double local) const {
  if (mPartition) mPartition->sumOverRanks(&local, 1);
  return local;
}

template <typename F>
double TimeStepDFSPH::sumOf(std::size_t n, F&& f) {
  if (mPartition == nullptr) return deterministicSum(n, f);
  // Over ranks: the same bits however the particles are split (ReproducibleSum.h).
  mTerms.resize(n);
  forEachIndex(n, [&](std::size_t i) { mTerms[i] = f(i); });
  return reproducibleSum(mTerms, mPartition);
}

Vec3r TimeStepDFSPH::velocityChange(const Real* step, std::size_t i) const {
  const PairTerm* pair = mPairs.data() + mPairOffsets[i];
  const std::uint32_t count = mPairCount[i];
  Vec3r dv = Vec3r::Zero();
#ifdef CASCADE_DFSPH_AVX2
  if (mHalfInstructions) dv = rowChangeF16c(pair, count, step);
  else
#endif
    for (std::uint32_t k = 0; k < count; ++k) dv += step[pair[k].neighbor] * pair[k].value();
  const std::uint32_t l = mLayerIndex[i];
  if (l != kNotInLayer)
    for (std::uint32_t g = mGhostOffsets[l]; g < mGhostOffsets[l + 1]; ++g) dv += step[mGhostSource[g]] * mGhostGradient[g];
  return dv + step[i] * mGradientSum[i];
}

Real TimeStepDFSPH::operatorEntry(std::size_t i, std::size_t j) const {
  const std::size_t n = mFactor.size();
  std::vector<Real> step(n, Real(0));
  step[j] = Real(1);
  std::vector<Vec3r> change(n);
  for (std::size_t k = 0; k < n; ++k) change[k] = velocityChange(step.data(), k);
  return divergence(change, i);
}

/// D(rho_i / rho_0)/Dt = sum_j V (v_i - v_j) . grad W_ij = v_i . G_i - sum_j v_j . V grad W_ij
/// over fluid and mirror neighbours (a mirror moves with its source, its velocity mirrored
/// (free slip) or reversed (no slip)), plus what a moving wall adds (mWallRate).
Real TimeStepDFSPH::densityRate(const std::vector<Vec3r>& velocity, std::size_t i) const {
  const std::uint32_t l = mLayerIndex[i];
  return divergence(velocity, i) - (l != kNotInLayer ? mWallRate[l] : Real(0));
}

/// The linear part of densityRate(): the walls' own motion left out.
Real TimeStepDFSPH::divergence(const std::vector<Vec3r>& velocity, std::size_t i) const {
  const PairTerm* pair = mPairs.data() + mPairOffsets[i];
  const std::uint32_t count = mPairCount[i];
  Real rate = 0;
#ifdef CASCADE_DFSPH_AVX2
  if (mHalfInstructions) rate = rowDivergenceF16c(pair, count, velocity.data());
  else
#endif
    for (std::uint32_t k = 0; k < count; ++k) rate += velocity[pair[k].neighbor].dot(pair[k].value());
  const std::uint32_t l = mLayerIndex[i];
  if (l != kNotInLayer) {
    for (std::uint32_t g = mGhostOffsets[l]; g < mGhostOffsets[l + 1]; ++g)
      rate += velocity[mGhostSource[g]].dot(mGhostVelocityGradient[g]);
  }
  return velocity[i].dot(mGradientSum[i]) - rate;
}

double TimeStepDFSPH::maxTimeStep(const DerivedConstants& constants) const {
  const double largest = parallelMaximum(mDensityKappa.size(), [&](std::size_t i) {
    return double(mDensityKappa[i] + (i < mDivergenceKappa.size() ? mDivergenceKappa[i] : Real(0)));
  });
  if (!(largest > 0)) return std::numeric_limits<double>::infinity();
  return kStiffnessStepFactor * double(constants.supportRadius) / std::sqrt(largest);
}

/// The constant-density solve as the bound-constrained problem of BoundConstrainedCG.h in
/// the stiffness kappa >= 0 (A = dt^2 D G: the density change per stiffness, D the density
/// rate and G the velocity change of applyStep; b = the residual at kappa = 0), Jacobi-scaled
/// with S_i = 1 / sqrt(A_ii) = sqrt(alpha_i) / dt (a particle with alpha_i = 0 is inert).
/// Starts from kappa (the warm start: applied to the velocities first), leaves the solution
/// in kappa and the velocities it gives, and the mean predicted compression left in
/// meanCompression. It stops at `tolerance` on the sum of the compressions and at
/// `share` x particleTolerance on each particle's (share 0: by the preconditioner that
/// runs, kTwoLevelResidualShare or kMaxResidualShare).
template <typename Residual>
BoundConstrainedResult TimeStepDFSPH::solveOneSided(std::vector<Vec3r>& velocity, std::vector<Real>& kappa, Real dt,
                                                    Residual&& residual, double tolerance, double particleTolerance,
                                                    double share,
                                                    int maxProducts, double& meanCompression) {
  const std::size_t n = mOwned;  // the unknowns: this rank's particles (the halo's come from their owners)
  std::vector<double>& S = mScaling;
  S.resize(n);
  mSolution.resize(n);
  mGradient.resize(n);
  mChange.resize(velocity.size());
  const double scale = double(dt) * double(dt);
  forEachIndex(n, [&](std::size_t i) {
    S[i] = mFactor[i] > 0 ? std::sqrt(double(mFactor[i]) / scale) : 0.0;
    mKappaStep[i] = S[i] > 0 ? std::max(kappa[i], Real(0)) : Real(0);
    kappa[i] = 0;
  });
  applyStep(velocity, kappa, dt);
  std::vector<double>& x = mSolution;
  std::vector<double>& g = mGradient;
  forEachIndex(n, [&](std::size_t i) {
    x[i] = S[i] > 0 ? double(kappa[i]) / S[i] : 0.0;
    g[i] = -S[i] * double(residual(i));
  });
  struct Problem {
    TimeStepDFSPH& self;
    const std::vector<double>& S;
    double scale, tolerance, maxResidual = 0;
    void product(const std::vector<double>& p, std::vector<double>& out, double& pAp) {
      const std::size_t count = p.size();
      forEachIndex(count, [&](std::size_t i) { self.mKappaStep[i] = Real(S[i] * p[i]); });
      self.shareWithHalo(self.mKappaStep.data());
      forEachIndex(count, [&](std::size_t i) { self.mChange[i] = self.velocityChange(self.mKappaStep.data(), i); });
      self.shareWithHalo(self.mChange.data());
      pAp = self.sumOf(count, [&](std::size_t i) {
        out[i] = S[i] > 0 ? S[i] * scale * double(self.divergence(self.mChange, i)) : 0.0;
        return p[i] * out[i];
      });
    }
    double weight(std::size_t i) const { return S[i] > 0 ? 1.0 / S[i] : 0.0; }
  } problem{*this, S, scale, tolerance};
  // Over MPI ranks: sums and maxima over every rank (BoundConstrainedCG.h's optional concept).
  struct SplitProblem : Problem {
    double sumTerms(std::vector<double>& terms) const { return reproducibleSum(terms, this->self.mPartition); }
    double largest(double local) const { return this->self.mPartition->maxOverRanks(local); }
  };
  SplitProblem split{problem};
  // The two-level preconditioner (solver.preconditioner = two_level; one process: the
  // coarse operator is not split over ranks): coarse cells of 2 h, the smallest that
  // couple only neighbouring cells (CoarseCorrection.h).
  struct TwoLevelProblem : Problem {
    const CoarseCorrection* coarse;
    void precondition(std::vector<double>& z, const std::vector<char>& bound) const { coarse->apply(z, bound); }
  };
  bool twoLevel = false;
  if (mTwoLevel && mPartition == nullptr) {
    twoLevel = mCoarse.build(mPosition, S, Real(2) * mSupportRadius, scale,
                             [&](std::size_t k, std::vector<CoarseCorrection::Coefficient>& row) {
                               // the velocity change of k per unit stiffness of each source (velocityChange)
                               row.push_back({std::uint32_t(k), mGradientSum[k]});
                               const PairTerm* pair = mPairs.data() + mPairOffsets[k];
#ifdef CASCADE_DFSPH_AVX2
                               if (mHalfInstructions)
                                 appendRowF16c(pair, mPairCount[k], row);
                               else
#endif
                                 for (std::uint32_t q = 0; q < mPairCount[k]; ++q)
                                   row.push_back({pair[q].neighbor, pair[q].value()});
                               const std::uint32_t l = mLayerIndex[k];
                               if (l != kNotInLayer)
                                 for (std::uint32_t g = mGhostOffsets[l]; g < mGhostOffsets[l + 1]; ++g)
                                   row.push_back({mGhostSource[g], mGhostGradient[g]});
                             });
  }
  // The per-particle bound of the preconditioner that runs (a coarse correction that
  // could not be built leaves Jacobi, with its own bound).
  problem.maxResidual = (share > 0 ? share : twoLevel ? kTwoLevelResidualShare : kMaxResidualShare) * particleTolerance;
  split.maxResidual = problem.maxResidual;
  TwoLevelProblem preconditioned{problem, &mCoarse};
  const BoundConstrainedResult result = mPartition ? solveBoundConstrained(split, x, g, maxProducts)
                                        : twoLevel ? solveBoundConstrained(preconditioned, x, g, maxProducts)
                                                   : solveBoundConstrained(problem, x, g, maxProducts);
  forEachIndex(n, [&](std::size_t i) { mKappaStep[i] = Real(S[i] * x[i]) - kappa[i]; });
  applyStep(velocity, kappa, dt);
  // The mean compression left, from the solve's own residual (g = -S r); an inert particle's
  // is measured (it has no place in the solve).
  meanCompression = sumOf(n, [&](std::size_t i) {
                      return S[i] > 0 ? std::max(-g[i] / S[i], 0.0) : double(std::max(residual(i), Real(0)));
                    }) /
                    mGlobalCount;
  return result;
}

void TimeStepDFSPH::advance(StepContext& c, Real dt) {
  Particles& particles = c.particles;
  const std::size_t n = particles.size();
  resize(n);
  mStatistics = Statistics();
  std::fill(c.obstacleForce.begin(), c.obstacleForce.end(), Vec3d::Zero());
  std::fill(c.obstacleMoment.begin(), c.obstacleMoment.end(), Vec3d::Zero());
  std::fill(c.reportedObstacleForce.begin(), c.reportedObstacleForce.end(), Vec3d::Zero());
  // Over MPI ranks the unknowns are the owned particles [0, owned); the halo after them
  // takes its values from the owners (shareWithHalo) and sums run over every rank.
  mPartition = c.partition;
  mTwoLevel = c.settings.solver.twoLevelPreconditioner;
  mOwned = c.ownedCount();
  mGlobalCount = std::max(overRanks(double(mOwned)), 1.0);
  if (n == 0 && mPartition == nullptr) return;
  const SolverSettings& solver = c.settings.solver;
  // Pair rows in particle order, packed (the search's lists may lie in its own order with
  // room between them): every operator product streams them front to back.
  const NeighborLists& lists = c.neighbors;
  mRowOffsets.resize(lists.size() + 1);
  mRowOffsets[0] = 0;
  for (std::size_t i = 0; i < lists.size(); ++i) mRowOffsets[i + 1] = mRowOffsets[i] + lists.count(i);
  mPairOffsets = mRowOffsets.data();

  auto start = Clock::now();
  prepare(c);
  c.timings.density += millisecondsSince(start);

  start = Clock::now();
  mKappaStep.resize(n);
  std::vector<Vec3r>& velocity = particles.velocity;
  const std::vector<MirrorMap>& maps = c.boundary.mirrors();

  // A step the Simulation shortened to land on a frame or probe time (it then sets
  // the step's upper bound to the remaining time: dt == maxTimeStep) and that is much
  // shorter than the last regular step removes only its share dt / dt_regular of the
  // density error already there, not all of it within dt (that would need speeds of
  // error * spacing / dt), and keeps the warm starts of the regular steps.
  const bool shortStep = dt == solver.maxTimeStep && mRegularStep > 0 && double(dt) < 0.5 * mRegularStep;
  const Real errorShare = shortStep ? static_cast<Real>(double(dt) / mRegularStep) : Real(1);
  if (!shortStep) mRegularStep = dt;
  std::vector<Real> savedDensityKappa, savedDivergenceKappa;
  if (shortStep) {
    savedDensityKappa = mDensityKappa;
    savedDivergenceKappa = mDivergenceKappa;
  }
  const int maxIterations = std::max(1, solver.maxIterations);

  // Each solve (Jacobi, compression only: kappa_i += max(r_i, 0) alpha_i / dt^k): the
  // warm start as the first increment, then sweeps of (apply the increments) and
  // (residuals, next increments, error).

  // --- 2. divergence-free solve (B&K 2017 alg. 2) ---
  {
    const Real inverseDt = Real(1) / dt;
    // Residual: relative density change per second, compression only (0 at the free surface,
    // B&K 2017); the rate itself is kept (mRate) for the density solve's warm start.
    auto sweep = [&](std::size_t i) -> double {
      const Real rate = densityRate(velocity, i);
      mRate[i] = rate;
      const Real r = mNeighborCount[i] < kMinDivergenceNeighbors ? Real(0) : std::max(rate, Real(0));
      mKappaStep[i] = r * mFactor[i] * inverseDt;
      return double(r);
    };
    // Warm start where the velocity field compresses (rates from prepare()).
    forEachIndex(mOwned, [&](std::size_t i) {
      const bool compressing = mNeighborCount[i] >= kMinDivergenceNeighbors && mRate[i] > 0;
      mKappaStep[i] = compressing ? kDivergenceWarmStart * mDivergenceKappa[i] : Real(0);
      mDivergenceKappa[i] = 0;
    });
    applyStep(velocity, mDivergenceKappa, dt);
    double error = sumOf(mOwned, sweep);
    const double tolerance = double(solver.divergenceTolerance) / double(dt) * mGlobalCount;
    int iterations = 0;
    while (iterations < maxIterations && error > tolerance) {
      applyStep(velocity, mDivergenceKappa, dt);
      error = sumOf(mOwned, sweep);
      ++iterations;
    }
    mStatistics.divergenceIterations = iterations;
    mStatistics.divergenceError = error / mGlobalCount * double(dt);
  }
  c.timings.forces += millisecondsSince(start);

  // --- 3. non-pressure accelerations (gravity, viscosity; computed in prepare()) ---
  start = Clock::now();
  {
    const std::vector<Vec3r>& acceleration = c.acceleration;
    // The force limit's acceleration: gravity; the viscous part is bounded by its rate
    // (needs().dampingStep). With rigid bodies the water moves, every non-pressure
    // acceleration, as before: the fluid force they feel holds at those shorter steps (at
    // 2.6 ms instead of 1.7 the near-neutral cube of 800 floated 2.3 % high instead of
    // 1.7 %, and tilted 2.9 degrees, bound 2; docs/dfsph-deep-water.md, "The time step").
    const double maxA = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, mOwned, 4096), 0.0,
        [&](const auto& range, double m) {
          for (std::size_t i = range.begin(); i != range.end(); ++i) {
            velocity[i] += dt * acceleration[i];
            m = std::max(m, double(acceleration[i].squaredNorm()));
          }
          return m;
        },
        [](double a, double b) { return std::max(a, b); });
    c.maxAcceleration = c.coupledBodies ? static_cast<Real>(std::sqrt(maxA)) : solver.gravity.norm();
  }
  if (c.settings.boundary.slip == MirrorSlip::LaminarWallShear) applyWallShear(c, dt);
  c.timings.integrate += millisecondsSince(start);

  // --- 4. constant-density solve (B&K 2017 alg. 3, solved as a bound-constrained problem) ---
  start = Clock::now();
  {
    // Residual: predicted compression rho*/rho_0 - 1 = existing + dt D(rho/rho_0)/Dt.
    auto residual = [&](std::size_t i) -> Real {
      const Real existing = std::min(errorShare * (mDensityRatio[i] - Real(1)), kMaxErrorPerStep);
      return existing + dt * densityRate(velocity, i);
    };
    const double tolerance = kDensityToleranceMargin * double(solver.densityTolerance);
    const BoundConstrainedResult result =
        solveOneSided(velocity, mDensityKappa, dt, residual, tolerance * mGlobalCount, tolerance,
                      double(solver.particleToleranceShare), maxIterations, mStatistics.densityError);
    mStatistics.densityIterations = result.products;
  }
  c.timings.forces += millisecondsSince(start);

  // --- 5. force on the boundaries, positions, pressure ---
  // A shortened step reports the last regular step's pressure and forces. With the half
  // warm start of the earlier Jacobi solve its own stiffness was not the pressure of the
  // water (a resting tank's floor read 0.58-0.92 rho g H at 100 Hz probe times, 0.99 at
  // regular steps, measured); frames and probes land on shortened steps, so they report
  // regular ones.
  if (mPartition) {
    // The halo copies' stiffness, for the mirror pairs' forces below.
    shareWithHalo(mDensityKappa.data());
    shareWithHalo(mDivergenceKappa.data());
    if (shortStep) {
      shareWithHalo(savedDensityKappa.data());
      shareWithHalo(savedDivergenceKappa.data());
    }
  }
  const std::vector<Real>& reportedDensityKappa = shortStep ? savedDensityKappa : mDensityKappa;
  const std::vector<Real>& reportedDivergenceKappa = shortStep ? savedDivergenceKappa : mDivergenceKappa;
  start = Clock::now();
  const std::size_t boundaryCount = c.obstacleForce.size();
  const std::vector<std::uint32_t>& layer = c.boundary.layer();
  // Over ranks the sums below are collective: every rank takes part, with or without a layer.
  if ((!layer.empty() && !maps.empty()) || (mPartition && boundaryCount > 0)) {
    // Everything the walls did to the fluid this step, as forces on them (the negative
    // of the impulse each wall gave the fluid, over dt), summed as ReactionSums.h does:
    // - the mirror pairs' pressure: m (kappa_i + kappa_j) V grad W_ij' with kappa the step's
    //   total (divergence and density solves);
    // - the mirror pairs' viscous terms (mGhostViscous);
    // - the no-penetration limiter below.
    // obstacleForce is that exchange exactly (what moves a rigid body: action = reaction);
    // reportedObstacleForce takes a shortened step's pressure from the last regular step
    // (as the particles' pressure above), for probes.
    // No penetration: the solves only resist compression, so a particle of the
    // (under-dense) free surface could creep into a wall. Its normal velocity towards
    // each wall it mirrors across (single reflections: trace 1), relative to the wall, is
    // limited so that it stays at least a quarter spacing off the wall.
    const Real mass = c.constants.particleMass;
    const Real minDistance = Real(0.25) * c.settings.fluid.spacing;
    const std::vector<std::uint32_t>& mapOffsets = c.boundary.mirrorOffsets();
    ReactionSums reactions(layer.size(), boundaryCount, 3, mPartition);  // force, reported, moment
    tbb::parallel_for(std::size_t(0), ReactionSums::chunks(layer.size()), [&](std::size_t chunk) {
      const std::size_t end = std::min(layer.size(), (chunk + 1) * ReactionSums::kChunk);
      for (std::size_t k = chunk * ReactionSums::kChunk; k < end; ++k) {
        const std::uint32_t i = layer[k];
        if (i >= mOwned || maps.empty()) continue;  // a halo copy: its owner counts it
        Vec3d* const force = reactions.record(k);
        Vec3d* const reported = force + boundaryCount;
        Vec3d* const moment = reported + boundaryCount;
        const Vec3r xi = particles.position[i];
        const Real ki = mDensityKappa[i] + mDivergenceKappa[i];
        const Real reportedKi = reportedDensityKappa[i] + reportedDivergenceKappa[i];
        if (boundaryCount > 0 && !mGhostSource.empty())
          for (std::uint32_t g = mGhostOffsets[k]; g < mGhostOffsets[k + 1]; ++g) {
            const std::uint32_t j = mGhostSource[g];
            const MirrorMap& map = maps[mGhostMap[g]];
            const std::uint32_t owner = map.boundary;
            if (owner >= boundaryCount) continue;
            const Vec3r viscous = mass * mGhostViscous[g];
            const Vec3d f = (mass * (ki + mDensityKappa[j] + mDivergenceKappa[j]) * mGhostGradient[g] - viscous).cast<double>();
            force[owner] += f;
            reported[owner] += (mass * (reportedKi + reportedDensityKappa[j] + reportedDivergenceKappa[j]) * mGhostGradient[g] -
                                viscous).cast<double>();
            // acting where the map's plane is (halfway to i's own image)
            moment[owner] += (Real(0.5) * (xi + map.apply(xi))).cast<double>().cross(f);
          }
        for (std::uint32_t m = mapOffsets[i]; m < mapOffsets[i + 1]; ++m) {
          const MirrorMap& map = maps[m];
          if (std::abs(map.linear.trace() - Real(1)) > Real(1e-3)) continue;
          const Vec3r toImage = xi - map.apply(xi);  // 2 d n
          const Real twice = toImage.norm();
          if (!(twice > Real(0))) continue;
          const Vec3r normal = toImage / twice;
          const Real distance = Real(0.5) * twice;
          const Real wallSpeed = map.wallVelocity.dot(normal);  // a moving wall's, along the normal
          const Real normalSpeed = velocity[i].dot(normal) - wallSpeed;
          const Real limit = (minDistance - distance) / dt;  // speed that lands on minDistance
          if (!(normalSpeed < limit)) continue;
          const Vec3r change = (std::min(limit, Real(0)) - normalSpeed) * normal;
          velocity[i] += change;
          if (map.boundary >= boundaryCount) continue;
          const Vec3d f = (-(mass / dt) * change).cast<double>();
          force[map.boundary] += f;
          reported[map.boundary] += f;
          moment[map.boundary] += (Real(0.5) * (xi + map.apply(xi))).cast<double>().cross(f);
        }
      }
    });
    const std::vector<Vec3d> totals = reactions.totals();  // collective over ranks
    for (std::size_t b = 0; b < boundaryCount; ++b) {
      c.obstacleForce[b] = totals[reactions.index(0, b)];
      c.reportedObstacleForce[b] = totals[reactions.index(1, b)];
      c.obstacleMoment[b] = totals[reactions.index(2, b)];
    }
  }
  c.timings.boundary += millisecondsSince(start);
  start = Clock::now();
  {
    const Real restDensity = c.settings.fluid.restDensity;
    forEachIndex(n, [&](std::size_t i) {
      particles.position[i] += dt * velocity[i];
      const Real rho = particles.density[i];
      // kappa = rho_0 p / rho^2; both solves' impulses make up the pressure of the step
      particles.pressure[i] = (reportedDensityKappa[i] + reportedDivergenceKappa[i]) * rho * rho / restDensity;
    });
  }
  if (shortStep) {
    mDensityKappa.swap(savedDensityKappa);
    mDivergenceKappa.swap(savedDivergenceKappa);
  }
  c.timings.integrate += millisecondsSince(start);
}

} // namespace cascade
