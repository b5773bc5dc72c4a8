/// @file Ply.h
/// @brief Reading the PLY format (G. Turk 1994, "The PLY Polygon File Format"):
///        the header (elements, their scalar and list properties, comments) and
///        the records of each element in file order, ascii or
///        binary_little_endian. Shared by the particle reader (ParticleCache.h:
///        points from other tools) and the mesh reader (TriangleMesh.h: readPly).
///        Every malformed or truncated file throws InputError naming the file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cascade {

enum class PlyType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;       ///< the value's type; a list's item type
  bool isList = false;
  PlyType countType = PlyType::UInt8;    ///< a list's count type
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
  /// Index of the property called `name`, or -1.
  int find(const std::string& name) const;
};

/// Bytes of a value of `type`.
std::size_t plyTypeSize(PlyType type);

/// A PLY file read into memory, walked element by element.
class PlyReader {
public:
  /// Reads `path` and its header; throws InputError if it is missing or not PLY.
  /// With `headerOnly`, only the header is read (elements() and comments(); no read()).
  explicit PlyReader(const std::filesystem::path& path, bool headerOnly = false);

  const std::vector<PlyElement>& elements() const { return mElements; }
  const std::vector<std::string>& comments() const { return mComments; }
  bool binary() const { return mBinary; }
  /// "file: " for messages.
  const std::string& where() const { return mWhere; }

  /// Reads the records of element number `index`: elements come in file order,
  /// so every element before it is skipped over (and must be whole). For each
  /// record, `record(values, list)` gets one double per property (a list
  /// property's slot holds its item count) and the items of the record's last
  /// list property (empty if it has none).
  template <class Record>
  void read(std::size_t index, Record&& record);

private:
  /// Moves to the first record of element `index`.
  void seek(std::size_t index);
  /// Reads one record of element `element` into mValues / mList.
  void readRecord(const PlyElement& element, std::size_t recordIndex);
  double readBinary(PlyType type, const PlyElement& element, std::size_t recordIndex);
  double readAscii(const PlyElement& element, std::size_t recordIndex);
  [[noreturn]] void truncated(const PlyElement& element, std::size_t recordIndex) const;

  std::string mWhere;
  std::string mData;
  std::vector<PlyElement> mElements;
  std::vector<std::string> mComments;
  bool mBinary = true;
  bool mHeaderOnly = false;
  std::size_t mBodyStart = 0;
  std::size_t mPosition = 0;   ///< next byte to read
  std::size_t mElement = 0;    ///< element the position is at the start of
  std::vector<double> mValues;
  std::vector<double> mList;
};

template <class Record>
void PlyReader::read(std::size_t index, Record&& record) {
  seek(index);
  const PlyElement& element = mElements[index];
  mValues.resize(element.properties.size());
  for (std::size_t i = 0; i < element.count; ++i) {
    readRecord(element, i);
    record(static_cast<const std::vector<double>&>(mValues), static_cast<const std::vector<double>&>(mList));
  }
  mElement = index + 1;
}

} // namespace cascade
