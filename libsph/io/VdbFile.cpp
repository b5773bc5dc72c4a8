#include "libsph/io/VdbFile.h"

#include "libsph/Errors.h"

#include <openvdb/io/Archive.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>
#include <openvdb/openvdb.h>

#include <fstream>
#include <mutex>

namespace cascade {

namespace {
/// Exposes Archive's header reader (protected in OpenVDB).
struct HeaderReader : openvdb::io::Archive {
  bool read(std::istream& stream) {
    const bool ok = readHeader(stream);
    // Tag the stream with the file's versions, as io::File::open does, so
    // that the descriptors are read in the file's format.
    setFormatVersion(stream);
    setLibraryVersion(stream);
    setDataCompression(stream);
    return ok;
  }
  bool hasGridOffsets() const { return inputHasGridOffsets(); }
};
} // namespace

void initializeOpenVdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

void validateVdbFile(const std::filesystem::path& path) {
  initializeOpenVdb();
  const std::string where = path.string() + ": ";
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(where + "no such file");
  const auto fileSize = static_cast<std::int64_t>(std::filesystem::file_size(path, error));
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw InputError(where + "cannot open file");
  try {
    HeaderReader header;
    header.read(stream);
    if (!header.hasGridOffsets()) throw InputError(where + "VDB file without grid offsets is not supported");
    openvdb::MetaMap fileMetadata;
    fileMetadata.readMeta(stream);
    std::int32_t gridCount = 0;
    stream.read(reinterpret_cast<char*>(&gridCount), sizeof gridCount);
    if (!stream || gridCount < 0) throw InputError(where + "truncated OpenVDB file (grid table)");
    for (std::int32_t g = 0; g < gridCount; ++g) {
      openvdb::io::GridDescriptor descriptor;
      descriptor.read(stream);
      if (!stream || descriptor.getEndPos() > fileSize || descriptor.getGridPos() > descriptor.getEndPos())
        throw InputError(where + "truncated OpenVDB file (grid " + std::to_string(g + 1) + " of " +
                         std::to_string(gridCount) + " incomplete)");
      stream.seekg(descriptor.getEndPos(), std::ios::beg);
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& failure) {
    throw InputError(where + "not a readable OpenVDB file (" + failure.what() + ")");
  }
}

} // namespace cascade
