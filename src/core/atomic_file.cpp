// Write-to-temporary-then-rename, so a failed or interrupted run leaves no half-written output.
#include "core/atomic_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "dsmplan/core.hpp"

namespace dsmplan {

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  namespace fs = std::filesystem;
  const fs::path target(path_);
  if (target.filename().empty()) throw OutputError(path_, "not a file name");
  std::error_code ec;
  if (fs::is_directory(target, ec)) throw OutputError(path_, "is a directory");
  // A device, pipe or socket cannot be replaced by renaming (and must not be: as root, /dev/full
  // would become a regular file); a whole-file writer can only refuse it.
  if (fs::exists(target, ec) && !fs::is_regular_file(target, ec))
    throw OutputError(path_, "cannot write: not a regular file (a device, pipe or socket); outputs are written to a "
                             "temporary file and renamed into place");
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  std::string pattern = (folder / ("." + target.filename().string() + ".partial-XXXXXX")).string();
  int fd = ::mkstemp(pattern.data());
  if (fd < 0) throw OutputError(path_, std::string("cannot write: ") + std::strerror(errno));
  temp_path_ = pattern;
  stream_ = ::fdopen(fd, "w+b");  // + : a writer may read back what it wrote (PlyStreamWriter)
  if (!stream_) {
    ::close(fd);
    ::unlink(temp_path_.c_str());
    throw OutputError(path_, std::string("cannot write: ") + std::strerror(errno));
  }
  std::setvbuf(stream_, nullptr, _IOFBF, 1 << 20);
}

AtomicFile::~AtomicFile() {
  if (stream_) std::fclose(stream_);
  if (!committed_) ::unlink(temp_path_.c_str());
}

void AtomicFile::close_stream() {
  if (stream_ && std::fclose(stream_) != 0) {
    stream_ = nullptr;
    fail(std::strerror(errno));
  }
  stream_ = nullptr;
}

void AtomicFile::fail(const std::string& why) {
  if (stream_) std::fclose(stream_);
  stream_ = nullptr;
  ::unlink(temp_path_.c_str());
  committed_ = true;  // nothing left to clean up
  throw OutputError(path_, "cannot write: " + why);
}

void AtomicFile::write(const void* data, size_t bytes) {
  if (bytes && std::fwrite(data, 1, bytes, stream_) != bytes) fail(std::strerror(errno));
}

void AtomicFile::commit() {
  if (stream_) {
    if (std::fflush(stream_) != 0) fail(std::strerror(errno));
    close_stream();
  }
  // mkstemp creates 0600; give the output the permissions a normal file would get.
  mode_t mask = ::umask(0);
  ::umask(mask);
  ::chmod(temp_path_.c_str(), 0666 & ~mask);
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0) fail(std::strerror(errno));
  committed_ = true;
}

}  // namespace dsmplan
