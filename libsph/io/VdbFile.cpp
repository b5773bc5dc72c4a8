#include "libsph/io/VdbFile.h"

#include "libsph/Errors.h"

#include <signal.h>
#include <unistd.h>

#include <openvdb/io/Archive.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>
#include <openvdb/openvdb.h>

#include <csignal>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
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

/// The checks below read a VDB's lengths and offsets without trusting them:
/// OpenVDB's own readers allocate (and zero-fill) whatever length a corrupt file
/// claims before the read fails, which took minutes and 11 GiB for a 778-byte file.
class LengthChecker {
public:
  LengthChecker(std::istream& stream, std::int64_t fileSize, std::string where)
      : mStream(stream), mFileSize(fileSize), mWhere(std::move(where)) {}

  template <class T>
  T read(const char* what) {
    T value{};
    mStream.read(reinterpret_cast<char*>(&value), sizeof value);
    if (!mStream) throw InputError(mWhere + "truncated OpenVDB file (" + what + ")");
    return value;
  }

  /// Skips a uint32 length and that many bytes (a string, or a metadata value).
  void skipSized(const char* what) {
    const std::uint32_t size = read<std::uint32_t>(what);
    if (std::int64_t(size) > mFileSize - std::int64_t(mStream.tellg()))
      throw InputError(mWhere + "corrupt OpenVDB file (" + what + " of " + std::to_string(size) +
                       " bytes, past the end of the file)");
    mStream.seekg(size, std::ios::cur);
  }

  /// Skips a metadata map (MetaMap::readMeta): a count, then name, type name and value.
  void skipMetadata(const char* what) {
    const std::uint32_t count = read<std::uint32_t>(what);
    if (std::int64_t(count) * 12 > mFileSize - std::int64_t(mStream.tellg()))
      throw InputError(mWhere + "corrupt OpenVDB file (" + what + ": " + std::to_string(count) + " entries)");
    for (std::uint32_t i = 0; i < count; ++i) {
      skipSized("metadata name");
      skipSized("metadata type");
      skipSized("metadata value");
    }
  }

private:
  std::istream& mStream;
  std::int64_t mFileSize;
  std::string mWhere;
};

/// The file this thread is reading with OpenVDB ("" when none), for the abort handler.
thread_local char tReading[4096] = "";

void onAbort(int signal) {
  if (tReading[0] != '\0') {
    static const char kCorrupt[] = ": corrupt OpenVDB file (OpenVDB failed reading it)\n";
    ssize_t ignored = ::write(2, tReading, std::strlen(tReading));
    ignored = ::write(2, kCorrupt, sizeof kCorrupt - 1);
    (void)ignored;
    ::_exit(kExitBadInput);
  }
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}
} // namespace

VdbReadScope::VdbReadScope(const std::filesystem::path& path) {
  std::strncpy(tReading, path.c_str(), sizeof tReading - 1);
  tReading[sizeof tReading - 1] = '\0';
}

VdbReadScope::~VdbReadScope() { tReading[0] = '\0'; }

void installVdbAbortGuard() {
  struct sigaction action {};
  action.sa_handler = onAbort;
  sigemptyset(&action.sa_mask);
  for (int signal : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE}) ::sigaction(signal, &action, nullptr);
}

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
    const std::uint32_t version = openvdb::io::getFormatVersion(stream);
    LengthChecker check(stream, fileSize, where);
    check.skipMetadata("file metadata");
    const std::int32_t gridCount = check.read<std::int32_t>("grid table");
    if (gridCount < 0) throw InputError(where + "truncated OpenVDB file (grid table)");
    for (std::int32_t g = 0; g < gridCount; ++g) {
      // The grid descriptor (GridDescriptor::read): name, type, instance parent, offsets.
      check.skipSized("grid name");
      check.skipSized("grid type");
      if (version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING) check.skipSized("instance parent");
      const auto gridPos = check.read<std::int64_t>("grid offsets");
      const auto blockPos = check.read<std::int64_t>("grid offsets");
      const auto endPos = check.read<std::int64_t>("grid offsets");
      if (!(0 <= gridPos && gridPos <= blockPos && blockPos <= endPos && endPos <= fileSize))
        throw InputError(where + "truncated OpenVDB file (grid " + std::to_string(g + 1) + " of " +
                         std::to_string(gridCount) + " incomplete)");
      // The grid's compression flags and its own metadata (Archive::readGrid).
      stream.seekg(gridPos, std::ios::beg);
      if (version >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) check.read<std::uint32_t>("grid compression");
      check.skipMetadata("grid metadata");
      stream.seekg(endPos, std::ios::beg);
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& failure) {
    throw InputError(where + "not a readable OpenVDB file (" + failure.what() + ")");
  }
}

} // namespace cascade
