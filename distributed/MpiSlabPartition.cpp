#include "distributed/MpiSlabPartition.h"

#include "libsph/Errors.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>

namespace cascade::distributed {

namespace {

using Clock = std::chrono::steady_clock;

/// Adds the wall time of its scope to a counter.
struct Timed {
  double& seconds;
  Clock::time_point begin = Clock::now();
  ~Timed() { seconds += std::chrono::duration<double>(Clock::now() - begin).count(); }
};

constexpr std::size_t kHistogramBins = 4096;

} // namespace

struct MpiSlabPartition::Record {
  Vec3r position, velocity;
  Real density, pressure;
  ParticleId id;
};

namespace {

using Record = MpiSlabPartition::Record;

Record recordOf(const Particles& particles, std::size_t i) {
  return {particles.position[i], particles.velocity[i], particles.density[i], particles.pressure[i], particles.id[i]};
}

void append(Particles& particles, const Record& r) {
  particles.add(r.position, r.velocity, r.id);
  particles.density.back() = r.density;
  particles.pressure.back() = r.pressure;
}

/// An MPI datatype of `bytes` contiguous bytes, freed at the end of its scope.
struct ContiguousType {
  MPI_Datatype type;
  explicit ContiguousType(std::size_t bytes) {
    MPI_Type_contiguous(int(bytes), MPI_BYTE, &type);
    MPI_Type_commit(&type);
  }
  ~ContiguousType() { MPI_Type_free(&type); }
  ContiguousType(const ContiguousType&) = delete;
  ContiguousType& operator=(const ContiguousType&) = delete;
};

} // namespace

MpiSlabPartition::MpiSlabPartition(MPI_Comm comm, std::ostream* log, double tolerance)
    : mComm(comm), mLog(log), mTolerance(tolerance) {
  MPI_Comm_rank(mComm, &mRank);
  MPI_Comm_size(mComm, &mSize);
  mGhostSends.resize(static_cast<std::size_t>(mSize));
  mGhostReceives.assign(std::size_t(mSize), 0);
}

void MpiSlabPartition::setFirstCuts(int axis, std::vector<Real> cuts) {
  mFirstAxis = axis;
  mFirstCuts = std::move(cuts);
  mTolerance = std::numeric_limits<double>::infinity();  // placed by hand: they stay
}

bool MpiSlabPartition::owns(const Vec3r& position) const { return mSlabs.ownerOf(position[mSlabs.axis]) == mRank; }

void MpiSlabPartition::start(const Particles& all, Real supportRadius, const Vec3r& lo, const Vec3r& hi,
                             const Vec3r& gravity) {
  const char axisName[] = {'x', 'y', 'z'};
  mSlabs.axis = mFirstAxis >= 0 ? mFirstAxis : slabAxis(lo, hi, gravity);
  const int axis = mSlabs.axis;
  std::vector<Real> coordinates(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) coordinates[i] = all.position[i][axis];
  // Room: the scene's box along the axis (where the fluid can go), in support radii.
  const double extent = std::max(0.0, double(hi[axis]) - double(lo[axis]));
  const long room = supportRadius > 0 ? long(std::floor(extent / double(supportRadius))) : 0;
  if (mSize > 1 && room < mSize) {
    std::ostringstream text;
    text << "mpirun -np " << mSize << ": the scene spans " << std::setprecision(3) << extent << " m along "
         << axisName[axis] << ", room for " << std::max(room, 0L) << " slab" << (room == 1 ? "" : "s")
         << " one support radius (" << supportRadius << " m) wide: run at most " << std::max(room, 1L) << " rank"
         << (room > 1 ? "s" : "");
    throw InputError(text.str());
  }
  // Equal shares of the starting fluid if it is wide enough to give each rank a slab;
  // otherwise (an emitter's first layer) equal slabs of the box, and rebalancing follows
  // the fluid as it comes.
  Real from = lo[axis], to = hi[axis];
  if (!coordinates.empty()) {
    from = *std::min_element(coordinates.begin(), coordinates.end());
    to = *std::max_element(coordinates.begin(), coordinates.end());
  }
  const bool wideFluid = double(to) - double(from) >= double(mSize) * double(supportRadius);
  if (!mFirstCuts.empty()) {
    if (int(mFirstCuts.size()) != mSize - 1 || !std::is_sorted(mFirstCuts.begin(), mFirstCuts.end()))
      throw InputError("--rank-cuts: needs " + std::to_string(mSize - 1) + " ascending coordinates for " +
                       std::to_string(mSize) + " ranks");
    mSlabs.cuts = mFirstCuts;
  } else if (wideFluid) {
    mSlabs.cuts = balancedCuts(coordinates, mSize);
  } else {
    mSlabs.cuts.clear();
    for (int r = 1; r < mSize; ++r) mSlabs.cuts.push_back(Real(double(lo[axis]) + extent * r / mSize));
  }
  std::vector<std::uint64_t> counts(std::size_t(mSize), 0);
  for (Real c : coordinates) ++counts[std::size_t(mSlabs.ownerOf(c))];
  logShares("start", counts);
}

void MpiSlabPartition::logShares(const char* when, const std::vector<std::uint64_t>& counts) const {
  if (mLog == nullptr || mRank != 0) return;
  const char axisName[] = {'x', 'y', 'z'};
  std::ostringstream line;
  line << "bake: " << mSize << " MPI rank" << (mSize > 1 ? "s" : "") << " (" << when << "), slabs along "
       << axisName[mSlabs.axis];
  if (!mSlabs.cuts.empty()) {
    line << " cut at";
    for (Real c : mSlabs.cuts) line << ' ' << std::setprecision(4) << c;
    line << " m";
  }
  line << "; particles per rank:";
  for (std::uint64_t c : counts) line << ' ' << c;
  *mLog << line.str() << '\n';
}

void MpiSlabPartition::exchange(const std::vector<std::vector<Record>>& outgoing, std::vector<Record>& received,
                                std::vector<int>* receivedCounts, const std::vector<std::vector<Real>>* outgoingState,
                                std::vector<Real>* receivedState, std::size_t width) {
  const ContiguousType record(sizeof(Record));
  std::vector<int> sendCounts(static_cast<std::size_t>(mSize)), recvCounts(static_cast<std::size_t>(mSize));
  std::vector<int> sendOffsets(static_cast<std::size_t>(mSize)), recvOffsets(static_cast<std::size_t>(mSize));
  std::vector<Record> send;
  for (int r = 0; r < mSize; ++r) {
    sendOffsets[std::size_t(r)] = int(send.size());
    sendCounts[std::size_t(r)] = int(outgoing[std::size_t(r)].size());
    send.insert(send.end(), outgoing[std::size_t(r)].begin(), outgoing[std::size_t(r)].end());
  }
  MPI_Alltoall(sendCounts.data(), 1, MPI_INT, recvCounts.data(), 1, MPI_INT, mComm);
  int total = 0;
  for (int r = 0; r < mSize; ++r) recvOffsets[std::size_t(r)] = total, total += recvCounts[std::size_t(r)];
  received.resize(std::size_t(total));
  MPI_Alltoallv(send.data(), sendCounts.data(), sendOffsets.data(), record.type, received.data(), recvCounts.data(),
                recvOffsets.data(), record.type, mComm);
  if (width > 0 && outgoingState && receivedState) {
    // The state: the same counts, `width` Reals each.
    const ContiguousType state(width * sizeof(Real));
    std::vector<Real> sendState;
    for (int r = 0; r < mSize; ++r)
      sendState.insert(sendState.end(), (*outgoingState)[std::size_t(r)].begin(), (*outgoingState)[std::size_t(r)].end());
    receivedState->resize(std::size_t(total) * width);
    MPI_Alltoallv(sendState.data(), sendCounts.data(), sendOffsets.data(), state.type, receivedState->data(),
                  recvCounts.data(), recvOffsets.data(), state.type, mComm);
  }
  if (receivedCounts) *receivedCounts = recvCounts;
}

void MpiSlabPartition::rebalance(const Particles& particles) {
  const int axis = mSlabs.axis;
  double range[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  for (const Vec3r& p : particles.position) {
    range[0] = std::min(range[0], double(p[axis]));
    range[1] = std::min(range[1], -double(p[axis]));
  }
  MPI_Allreduce(MPI_IN_PLACE, range, 2, MPI_DOUBLE, MPI_MIN, mComm);
  const Real lo = Real(range[0]), hi = Real(-range[1]);
  if (!(hi > lo)) return;
  std::vector<std::uint64_t> bins(kHistogramBins, 0);
  for (const Vec3r& p : particles.position) ++bins[histogramBin(p[axis], lo, hi, kHistogramBins)];
  MPI_Allreduce(MPI_IN_PLACE, bins.data(), int(bins.size()), MPI_UINT64_T, MPI_SUM, mComm);
  mSlabs.cuts = balancedCutsFromHistogram(bins, lo, hi, mSize);
  ++mRebalances;
}

void MpiSlabPartition::migrate(Particles& particles, std::vector<Real>* state, std::size_t width) {
  if (state == nullptr) width = 0;
  Timed timed{mCommunicationSeconds};
  // The shares the current cuts would give once the particles have moved.
  const int axis = mSlabs.axis;
  std::vector<std::uint64_t> counts(static_cast<std::size_t>(mSize), 0);
  for (const Vec3r& p : particles.position) ++counts[std::size_t(mSlabs.ownerOf(p[axis]))];
  MPI_Allreduce(MPI_IN_PLACE, counts.data(), mSize, MPI_UINT64_T, MPI_SUM, mComm);
  const bool rebalancing = unbalanced(counts, mTolerance);
  if (rebalancing) rebalance(particles);

  std::vector<std::vector<Record>> outgoing(static_cast<std::size_t>(mSize));
  std::vector<std::vector<Real>> outgoingState(static_cast<std::size_t>(mSize));
  std::vector<char> leaving(particles.size(), 0);
  std::uint64_t sent = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const int owner = mSlabs.ownerOf(particles.position[i][axis]);
    if (owner == mRank) continue;
    outgoing[std::size_t(owner)].push_back(recordOf(particles, i));
    if (width > 0)
      outgoingState[std::size_t(owner)].insert(outgoingState[std::size_t(owner)].end(), state->begin() + long(i * width),
                                               state->begin() + long((i + 1) * width));
    leaving[i] = 1;
    ++sent;
  }
  std::vector<Record> received;
  std::vector<Real> receivedState;
  exchange(outgoing, received, nullptr, &outgoingState, &receivedState, width);
  if (sent > 0) {
    particles.removeIf(leaving);
    if (width > 0) {
      std::size_t out = 0;
      for (std::size_t i = 0; i < leaving.size(); ++i)
        if (!leaving[i]) std::copy_n(state->begin() + long(i * width), width, state->begin() + long(out++ * width));
      state->resize(out * width);
    }
  }
  if (width > 0) state->insert(state->end(), receivedState.begin(), receivedState.end());
  particles.reserve(particles.size() + received.size());
  for (const Record& r : received) append(particles, r);
  mMigrated += sent;
  if (rebalancing) {
    const std::uint64_t local = particles.size();
    MPI_Allgather(&local, 1, MPI_UINT64_T, counts.data(), 1, MPI_UINT64_T, mComm);
    logShares("rebalanced", counts);
  }
}

void MpiSlabPartition::addGhosts(Particles& particles, Real halo) {
  Timed timed{mCommunicationSeconds};
  const int axis = mSlabs.axis;
  const Real lower = mRank > 0 ? mSlabs.cuts[std::size_t(mRank - 1)] : -std::numeric_limits<Real>::infinity();
  const Real upper = mRank < mSize - 1 ? mSlabs.cuts[std::size_t(mRank)] : std::numeric_limits<Real>::infinity();
  std::vector<std::vector<Record>> outgoing(static_cast<std::size_t>(mSize));
  for (auto& sends : mGhostSends) sends.clear();
  const std::size_t owned = particles.size();
  for (std::size_t i = 0; i < owned; ++i) {
    const Real c = particles.position[i][axis];
    if (c >= lower + halo && c < upper - halo) continue;  // deep inside: no other slab is near
    int first = 0, last = 0;
    mSlabs.ranksWithin(c, halo, first, last);
    for (int r = first; r <= last; ++r) {
      if (r == mRank) continue;
      mGhostSends[std::size_t(r)].push_back(std::uint32_t(i));
      outgoing[std::size_t(r)].push_back(recordOf(particles, i));
    }
  }
  std::vector<Record> received;
  exchange(outgoing, received, &mGhostReceives);
  particles.reserve(owned + received.size());
  for (const Record& r : received) append(particles, r);
  mGhostCount = received.size();
}

template <typename T>
void MpiSlabPartition::refresh(T* values, std::size_t ownedCount) {
  Timed timed{mCommunicationSeconds};
  std::vector<int> sendCounts(static_cast<std::size_t>(mSize)), recvCounts(static_cast<std::size_t>(mSize));
  std::vector<int> sendOffsets(static_cast<std::size_t>(mSize)), recvOffsets(static_cast<std::size_t>(mSize));
  std::vector<T> send;
  int received = 0;
  for (int r = 0; r < mSize; ++r) {
    sendOffsets[std::size_t(r)] = int(send.size() * sizeof(T));
    for (std::uint32_t i : mGhostSends[std::size_t(r)]) send.push_back(values[i]);
    sendCounts[std::size_t(r)] = int(mGhostSends[std::size_t(r)].size() * sizeof(T));
    recvOffsets[std::size_t(r)] = int(std::size_t(received) * sizeof(T));
    recvCounts[std::size_t(r)] = int(std::size_t(mGhostReceives[std::size_t(r)]) * sizeof(T));
    received += mGhostReceives[std::size_t(r)];
  }
  MPI_Alltoallv(send.data(), sendCounts.data(), sendOffsets.data(), MPI_BYTE, values + ownedCount, recvCounts.data(),
                recvOffsets.data(), MPI_BYTE, mComm);
}

void MpiSlabPartition::refreshGhosts(Real* values, std::size_t ownedCount) { refresh(values, ownedCount); }
void MpiSlabPartition::refreshGhosts(Vec3r* values, std::size_t ownedCount) { refresh(values, ownedCount); }

void MpiSlabPartition::maxOverRanks(double* values, std::size_t count) {
  Timed timed{mCommunicationSeconds};
  MPI_Allreduce(MPI_IN_PLACE, values, int(count), MPI_DOUBLE, MPI_MAX, mComm);
}

void MpiSlabPartition::sumOverRanks(double* values, std::size_t count) {
  Timed timed{mCommunicationSeconds};
  std::vector<double> all(count * std::size_t(mSize));
  MPI_Allgather(values, int(count), MPI_DOUBLE, all.data(), int(count), MPI_DOUBLE, mComm);
  for (std::size_t k = 0; k < count; ++k) {
    double sum = 0;
    for (int r = 0; r < mSize; ++r) sum += all[std::size_t(r) * count + k];
    values[k] = sum;
  }
}

std::string MpiSlabPartition::firstMessage(const std::string& local) {
  Timed timed{mCommunicationSeconds};
  std::vector<int> lengths(static_cast<std::size_t>(mSize));
  int length = int(local.size());
  MPI_Allgather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, mComm);
  int first = -1;
  for (int r = 0; r < mSize && first < 0; ++r)
    if (lengths[std::size_t(r)] > 0) first = r;
  if (first < 0) return "";
  std::string message(std::size_t(lengths[std::size_t(first)]), '\0');
  if (mRank == first) message = local;
  MPI_Bcast(message.data(), int(message.size()), MPI_CHAR, first, mComm);
  return message;
}

Particles MpiSlabPartition::gatherToFirst(const Particles& owned, const std::vector<Real>* state, std::size_t width,
                                          std::vector<Real>* gatheredState) {
  if (state == nullptr || gatheredState == nullptr) width = 0;
  Timed timed{mCommunicationSeconds};
  const ContiguousType record(sizeof(Record));
  std::vector<Record> send(owned.size());
  for (std::size_t i = 0; i < owned.size(); ++i) send[i] = recordOf(owned, i);
  int count = int(send.size());
  std::vector<int> counts(static_cast<std::size_t>(mSize)), offsets(static_cast<std::size_t>(mSize));
  MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, mComm);
  int total = 0;
  for (int r = 0; r < mSize; ++r) offsets[std::size_t(r)] = total, total += counts[std::size_t(r)];
  std::vector<Record> all(mRank == 0 ? std::size_t(total) : 0);
  MPI_Gatherv(send.data(), count, record.type, all.data(), counts.data(), offsets.data(), record.type, 0, mComm);
  std::vector<Real> allState;
  if (width > 0) {
    const ContiguousType stateType(width * sizeof(Real));
    allState.resize(all.size() * width);
    MPI_Gatherv(state->data(), count, stateType.type, allState.data(), counts.data(), offsets.data(), stateType.type, 0,
                mComm);
  }
  Particles out;
  out.mass = owned.mass;
  if (mRank != 0) return out;
  std::vector<std::uint32_t> order(all.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return all[a].id < all[b].id; });
  out.reserve(all.size());
  if (width > 0) gatheredState->resize(all.size() * width);
  for (std::size_t k = 0; k < order.size(); ++k) {
    append(out, all[order[k]]);
    if (width > 0)
      std::copy_n(allState.begin() + long(order[k] * width), width, gatheredState->begin() + long(k * width));
  }
  return out;
}

} // namespace cascade::distributed
