// Files mapped read-only (POSIX mmap) and hashed with XXH3 (xxHash, Yann Collet).
#include "core/mapped_file.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxh_x86dispatch.h>  // XXH3_64bits_dispatch: the same hash, on AVX2 or AVX-512 where the CPU has them
#include <xxhash.h>

#include <cerrno>
#include <cstring>
#include <thread>
#include <vector>

#include "dsmplan/core.hpp"

namespace dsmplan {

std::shared_ptr<const MappedFile> MappedFile::open(const std::string& path) {
  require_input_file(path);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path, "", std::string("cannot be opened: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw InputError(path, "", "is not a regular file");
  }
  std::shared_ptr<MappedFile> file(new MappedFile());
  file->size_ = static_cast<size_t>(st.st_size);
  if (file->size_ > 0) {
    void* at = ::mmap(nullptr, file->size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (at == MAP_FAILED) {
      const int error = errno;
      ::close(fd);
      throw InputError(path, "", std::string("cannot be mapped: ") + std::strerror(error));
    }
    file->data_ = static_cast<const unsigned char*>(at);
  }
  ::close(fd);  // the mapping keeps the file
  return file;
}

MappedFile::~MappedFile() {
  if (data_) ::munmap(const_cast<unsigned char*>(data_), size_);
}

uint64_t content_hash(const void* data, size_t bytes) { return content_hash(data, bytes, {}); }

uint64_t content_hash(const void* data, size_t bytes, const std::function<void(const unsigned char*, size_t)>& visit) {
  const auto* at = static_cast<const unsigned char*>(data);
  if (bytes <= hash_piece_bytes) {
    const uint64_t hash = XXH3_64bits_dispatch(at, bytes);
    if (visit && bytes > 0) visit(at, bytes);
    return hash;
  }
  // Pieces on every core: a mapped file's pages are faulted in by whichever thread reads them,
  // so the mapping's cost is spread as well.
  const size_t pieces = (bytes + hash_piece_bytes - 1) / hash_piece_bytes;
  std::vector<uint64_t> hashes(pieces);
  const unsigned threads = std::max(1u, std::min<unsigned>(std::thread::hardware_concurrency(), pieces));
  auto work = [&](unsigned first) {
    for (size_t k = first; k < pieces; k += threads) {
      const size_t n = std::min(hash_piece_bytes, bytes - k * hash_piece_bytes);
      hashes[k] = XXH3_64bits_dispatch(at + k * hash_piece_bytes, n);
      if (visit) visit(at + k * hash_piece_bytes, n);
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& t : pool) t.join();
  return XXH3_64bits_dispatch(hashes.data(), hashes.size() * sizeof(uint64_t));
}

uint64_t file_content_hash(const std::string& path) {
  const auto file = MappedFile::open(path);
  return content_hash(file->data(), file->size());
}

}  // namespace dsmplan
