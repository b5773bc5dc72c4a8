/// @file BinaryPod.h
/// @brief Exact binary save and restore of plain values (checkpoints): the bytes
///        of a plain value (numbers, fixed-size Eigen vectors and matrices),
///        written and read back as they are.
#pragma once

#include "libsph/Errors.h"

#include <istream>
#include <ostream>
#include <string>
#include <type_traits>

namespace cascade {

template <typename T>
void writePodValue(std::ostream& out, const T& value) {
  static_assert(std::is_standard_layout_v<T>, "plain values only");
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

/// Throws InputError("checkpoint: truncated <what>") if the stream ends first.
template <typename T>
void readPodValue(std::istream& in, T& value, const char* what) {
  static_assert(std::is_standard_layout_v<T>, "plain values only");
  in.read(reinterpret_cast<char*>(&value), sizeof(T));
  if (!in) throw InputError(std::string("checkpoint: truncated ") + what);
}

} // namespace cascade
