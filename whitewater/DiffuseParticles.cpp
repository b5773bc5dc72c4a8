// Diffuse particle arrays.
#include "whitewater/DiffuseParticles.h"

#include "libsph/Particles.h"

namespace cascade::whitewater {

const char* diffuseTypeName(DiffuseType type) {
  switch (type) {
    case DiffuseType::Spray: return "spray";
    case DiffuseType::Foam: return "foam";
    case DiffuseType::Bubble: return "bubble";
  }
  return "unknown";
}

void DiffuseParticles::reserve(std::size_t count) {
  position.reserve(count);
  velocity.reserve(count);
  id.reserve(count);
  age.reserve(count);
}

void DiffuseParticles::push_back(const Vec3r& x, const Vec3r& v, std::uint32_t identifier, float ageSeconds) {
  position.push_back(x);
  velocity.push_back(v);
  id.push_back(identifier);
  age.push_back(ageSeconds);
}

void DiffuseParticles::append(const DiffuseParticles& other) {
  position.insert(position.end(), other.position.begin(), other.position.end());
  velocity.insert(velocity.end(), other.velocity.begin(), other.velocity.end());
  id.insert(id.end(), other.id.begin(), other.id.end());
  age.insert(age.end(), other.age.begin(), other.age.end());
}

void DiffuseParticles::permute(const std::vector<std::size_t>& order) {
  permuteArray(position, order);
  permuteArray(velocity, order);
  permuteArray(id, order);
  permuteArray(age, order);
}

void DiffuseParticles::keepWhere(const std::vector<std::uint8_t>& keep) {
  std::size_t out = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (!keep[i]) continue;
    position[out] = position[i];
    velocity[out] = velocity[i];
    id[out] = id[i];
    age[out] = age[i];
    ++out;
  }
  position.resize(out);
  velocity.resize(out);
  id.resize(out);
  age.resize(out);
}

} // namespace cascade::whitewater
