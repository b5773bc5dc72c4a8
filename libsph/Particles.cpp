#include "libsph/Particles.h"

namespace cascade {

namespace {
template <typename T>
void compactArray(std::vector<T>& values, const std::vector<char>& remove) {
  std::size_t out = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!remove[i]) values[out++] = values[i];
  values.resize(out);
}
} // namespace

void Particles::permute(const std::vector<std::size_t>& order) {
  permuteArray(position, order);
  permuteArray(velocity, order);
  permuteArray(density, order);
  permuteArray(pressure, order);
  permuteArray(id, order);
}

std::size_t Particles::removeIf(const std::vector<char>& remove) {
  const std::size_t before = size();
  compactArray(position, remove);
  compactArray(velocity, remove);
  compactArray(density, remove);
  compactArray(pressure, remove);
  compactArray(id, remove);
  return before - size();
}

} // namespace cascade
