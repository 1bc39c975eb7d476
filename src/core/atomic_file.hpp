// Outputs appear whole or not at all: written under a temporary name in the target folder,
// renamed into place by commit(); destroyed without commit, the temporary file is removed.
#pragma once

#include <cstdio>
#include <string>

namespace dsmplan {

class AtomicFile {
public:
  /// Creates the temporary file next to `path`; OutputError when the folder is not writable or
  /// `path` exists and is not a regular file (a directory, device, pipe or socket).
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& path() const { return path_; }
  const std::string& temp_path() const { return temp_path_; }
  /// The open stream, for writers that write themselves (null after close_stream()).
  std::FILE* stream() { return stream_; }
  /// Closes the stream so another library (GDAL) can write temp_path() by name.
  void close_stream();

  void write(const void* data, size_t bytes);
  void write(const std::string& text) { write(text.data(), text.size()); }

  /// Flushes, closes and renames into place; OutputError on any failure (nothing left behind).
  void commit();

private:
  [[noreturn]] void fail(const std::string& why);
  std::string path_, temp_path_;
  std::FILE* stream_ = nullptr;
  bool committed_ = false;
  int slot_ = -1;  ///< where remove_partial_outputs_on_signals() finds temp_path_
};

}  // namespace dsmplan
