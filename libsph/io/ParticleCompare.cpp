#include "libsph/io/ParticleCompare.h"

#include "libsph/Errors.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace cascade {

ParticleDifference compareParticleFrames(const ParticleFrame& a, const ParticleFrame& b) {
  ParticleDifference d;
  const bool idsA = !a.id.empty(), idsB = !b.id.empty();
  if (idsA != idsB) throw InputError("the two caches cannot be matched: one has particle ids and the other none");
  d.byId = idsA;
  const bool velocities = !a.velocity.empty() && !b.velocity.empty();
  double sumPosition = 0, sumVelocity = 0;
  const auto pair = [&](std::size_t i, std::size_t j, ParticleId label) {
    const double dx = (a.position[i].cast<double>() - b.position[j].cast<double>()).norm();
    sumPosition += dx * dx;
    if (d.matched == 0 || dx > d.maxPosition) {
      d.maxPosition = dx;
      d.maxPositionId = label;
    }
    if (velocities) {
      const double dv = (a.velocity[i].cast<double>() - b.velocity[j].cast<double>()).norm();
      sumVelocity += dv * dv;
      d.maxVelocity = std::max(d.maxVelocity, dv);
    }
    ++d.matched;
  };
  if (d.byId) {
    std::unordered_map<ParticleId, std::size_t> inB;
    inB.reserve(b.size());
    for (std::size_t j = 0; j < b.size(); ++j) inB.emplace(b.id[j], j);
    for (std::size_t i = 0; i < a.size(); ++i) {
      const auto found = inB.find(a.id[i]);
      if (found == inB.end()) ++d.onlyInA;
      else pair(i, found->second, a.id[i]);
    }
    d.onlyInB = b.size() - d.matched;
  } else {
    const std::size_t common = std::min(a.size(), b.size());
    for (std::size_t i = 0; i < common; ++i) pair(i, i, ParticleId(i));
    d.onlyInA = a.size() - common;
    d.onlyInB = b.size() - common;
  }
  if (d.matched > 0) {
    d.rmsPosition = std::sqrt(sumPosition / double(d.matched));
    d.rmsVelocity = std::sqrt(sumVelocity / double(d.matched));
  }
  return d;
}

} // namespace cascade
