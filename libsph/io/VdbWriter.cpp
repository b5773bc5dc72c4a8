#include "libsph/io/VdbWriter.h"

#include "libsph/io/ActiveMaskLeafWriter.h"

#include <fcntl.h>
#include <unistd.h>

#include <openvdb/io/Archive.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <ostream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <vector>

namespace cascade {

namespace {

/// An output stream buffer over a file descriptor: writes gather in one buffer and
/// reach the file when it fills, on a seek and on close.
class FileWriteBuffer : public std::streambuf {
public:
  explicit FileWriteBuffer(const std::filesystem::path& path) : mPath(path), mBuffer(std::size_t(8) << 20) {
    mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (mFd < 0) fail(errno);
    setp(mBuffer.data(), mBuffer.data() + mBuffer.size());
  }
  ~FileWriteBuffer() override {
    if (mFd >= 0) ::close(mFd);
  }
  FileWriteBuffer(const FileWriteBuffer&) = delete;
  FileWriteBuffer& operator=(const FileWriteBuffer&) = delete;

  /// Writes what is buffered and closes the file; throws on any error so far.
  void close() {
    if (!flush()) fail(mError);
    const int fd = mFd;
    mFd = -1;
    if (::close(fd) != 0) fail(errno);
  }

protected:
  int_type overflow(int_type ch) override {
    if (!flush()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  std::streamsize xsputn(const char* data, std::streamsize count) override {
    std::streamsize done = 0;
    while (done < count) {
      const std::streamsize room = epptr() - pptr();
      if (room == 0) {
        if (!flush()) break;
        continue;
      }
      const std::streamsize piece = std::min(room, count - done);
      std::memcpy(pptr(), data + done, std::size_t(piece));
      pbump(int(piece));
      done += piece;
    }
    return done;
  }
  int sync() override { return flush() ? 0 : -1; }
  pos_type seekoff(off_type offset, std::ios_base::seekdir direction, std::ios_base::openmode which) override {
    if (!(which & std::ios_base::out) || !flush()) return pos_type(off_type(-1));
    const int whence = direction == std::ios_base::beg ? SEEK_SET : direction == std::ios_base::cur ? SEEK_CUR : SEEK_END;
    const off_t at = ::lseek(mFd, off_t(offset), whence);
    if (at < 0) mError = errno;
    return pos_type(off_type(at));
  }
  pos_type seekpos(pos_type position, std::ios_base::openmode which) override {
    return seekoff(off_type(position), std::ios_base::beg, which);
  }

private:
  bool flush() {
    if (mFd < 0 || mError != 0) return false;
    for (const char* at = pbase(); at < pptr();) {
      const ssize_t written = ::write(mFd, at, std::size_t(pptr() - at));
      if (written < 0) {
        if (errno == EINTR) continue;
        mError = errno;
        return false;
      }
      at += written;
    }
    setp(mBuffer.data(), mBuffer.data() + mBuffer.size());
    return true;
  }
  [[noreturn]] void fail(int error) const {
    throw std::runtime_error(mPath.string() + ": cannot write (" + std::strerror(error != 0 ? error : EIO) + ")");
  }

  std::filesystem::path mPath;
  std::vector<char> mBuffer;
  int mFd = -1;
  int mError = 0;
};

/// io::Archive's seekable write (what io::File::write calls) onto any stream.
class StreamArchive : public openvdb::io::Archive {
public:
  void writeSeekable(std::ostream& stream, const openvdb::GridCPtrVec& grids) const {
    Archive::write(stream, grids, /*seekable=*/true);
  }
};

} // namespace

void writeVdbFile(const std::filesystem::path& path, const openvdb::GridCPtrVec& grids, std::uint32_t compression) {
  FileWriteBuffer buffer(path);
  std::ostream stream(&buffer);
  // Float and Vec3s grids write their leaves through writeActiveMaskLeaf (the same bytes;
  // CASCADE_VDB_OPENVDB_LEAVES=1, a study knob, leaves them to OpenVDB to compare).
  static const bool openVdbLeaves = [] {
    const char* value = std::getenv("CASCADE_VDB_OPENVDB_LEAVES");
    return value && std::string(value) == "1";
  }();
  openvdb::GridCPtrVec writing;
  for (const openvdb::GridBase::ConstPtr& grid : grids) {
    if (openVdbLeaves) {
      writing.push_back(grid);
      continue;
    }
    if (const auto floats = openvdb::gridConstPtrCast<openvdb::FloatGrid>(grid))
      writing.push_back(std::make_shared<LeafWritingGrid<openvdb::FloatGrid>>(*floats));
    else if (const auto vectors = openvdb::gridConstPtrCast<openvdb::Vec3SGrid>(grid))
      writing.push_back(std::make_shared<LeafWritingGrid<openvdb::Vec3SGrid>>(*vectors));
    else
      writing.push_back(grid);
  }
  StreamArchive archive;
  archive.setCompression(compression);
  archive.writeSeekable(stream, writing);
  const bool written = bool(stream);
  buffer.close();  // throws with the error a failed write left
  if (!written) throw std::runtime_error(path.string() + ": cannot write");
}

} // namespace cascade
