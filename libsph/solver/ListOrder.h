/// @file ListOrder.h
/// @brief A parallel pass over every particle's neighbour list in the order the
///        lists lie in memory.
///
/// The grid search writes each chunk's lists straight into place, in its own
/// (cell) order (search/ListAssembly.h). Particles are put in that order at each
/// reorder, but drift from it as they change cells: on a splash a third of the
/// lists are out of particle order within ten steps. A pass that visits
/// particles by index then jumps between lists; visiting them in list order
/// reads the lists front to back (on the production tower, before the reorder
/// followed the grid's curve, the density and force passes each took 2.5 ms a
/// step longer in particle order: docs/boundary-sampling.md). Each particle's
/// work is its own, so the order does not change any result.
#pragma once

#include "libsph/NeighborSearch.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <cstdint>

namespace cascade {

/// Calls body(i) once for every list i < limit of `lists`, in parallel ranges of
/// `grain` lists, in the order the lists lie in memory (lists.order; by index when
/// it is empty).
template <typename Body>
void forEachInListOrder(const NeighborLists& lists, std::size_t limit, std::size_t grain, Body&& body) {
  const std::uint32_t* order = lists.order.size() == lists.size() ? lists.order.data() : nullptr;
  const std::size_t count = order ? lists.size() : limit;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, grain), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const std::size_t i = order ? order[k] : k;
      if (i < limit) body(i);
    }
  });
}

} // namespace cascade
