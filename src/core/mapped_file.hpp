// A file read where it lies: mapped into memory read-only, so a file the page cache holds costs
// no copy and no fresh pages (fresh pages are what loading large inputs spends its time in:
// bench/README.md, "Load"). And a fast hash of bytes, to tell whether an input has changed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace dsmplan {

class MappedFile {
public:
  /// Maps `path` whole, read-only. InputError(path, "", why) when it cannot be opened or mapped
  /// (a directory, a device); an empty file maps to size() 0.
  static std::shared_ptr<const MappedFile> open(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const unsigned char* data() const { return data_; }
  size_t size() const { return size_; }

private:
  MappedFile() = default;
  const unsigned char* data_ = nullptr;
  size_t size_ = 0;
};

/// XXH3-64 of the bytes (Collet, xxHash 0.8; https://github.com/Cyan4973/xxHash): tells whether
/// data changed (any one bit flips about half the hash's bits), not proof against a forger.
/// Inputs over hash_piece_bytes are hashed in pieces of that size on every core, then the
/// pieces' hashes (XXH3-64 of the array of them), so the value depends only on the bytes. About
/// 20 GB/s a core with AVX2.
uint64_t content_hash(const void* data, size_t bytes);
constexpr size_t hash_piece_bytes = size_t(1) << 20;

/// content_hash(), calling visit(piece, piece_bytes) on each piece (the pieces above: they start
/// at multiples of hash_piece_bytes from data) right after hashing it, on the thread that hashed
/// it, while the piece is in that core's cache: a check of the data costs no second trip to
/// memory. visit may run on several threads at once.
uint64_t content_hash(const void* data, size_t bytes,
                      const std::function<void(const unsigned char* piece, size_t piece_bytes)>& visit);

/// content_hash() of a file's bytes. InputError as MappedFile::open().
uint64_t file_content_hash(const std::string& path);

}  // namespace dsmplan
