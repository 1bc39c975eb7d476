// What an input path must be before a reader opens it (core.hpp, require_input_file()): a FIFO
// with no writer blocks open() forever, /dev/zero never ends, a directory reads as nothing; so
// each is refused from its stat(), which opens nothing.
#include <sys/stat.h>

#include <cstdio>
#include <string>

#include "dsmplan/core.hpp"

namespace dsmplan {

namespace {

std::string size_text(double bytes) {
  char text[32];
  if (bytes >= 1e9)
    std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
  else if (bytes >= 1e6)
    std::snprintf(text, sizeof text, "%.1f MB", bytes / 1e6);
  else
    std::snprintf(text, sizeof text, "%.0f kB", bytes / 1e3);
  return text;
}

}  // namespace

void require_input_file(const std::string& path, uint64_t max_bytes, const char* what) {
  // A NUL byte would cut the name where the system reads it: another file would be read.
  if (path.find('\0') != std::string::npos)
    throw InputError(path.substr(0, path.find('\0')) + "\\0...", "", "a file name with a NUL byte");
  struct stat info;
  if (::stat(path.c_str(), &info) != 0) return;  // missing: the reader says so in its own words
  const char* kind = S_ISDIR(info.st_mode)    ? "a directory"
                     : S_ISFIFO(info.st_mode) ? "a FIFO (named pipe)"
                     : S_ISCHR(info.st_mode)  ? "a character device"
                     : S_ISBLK(info.st_mode)  ? "a block device"
                     : S_ISSOCK(info.st_mode) ? "a socket"
                                              : nullptr;
  if (kind)
    throw InputError(path, "",
                     std::string("is ") + kind + ", not a file: dsmplan reads files of a known size (save a stream " +
                         "to a file first)");
  if (max_bytes > 0 && static_cast<uint64_t>(info.st_size) > max_bytes)
    throw InputError(path, "",
                     "is " + size_text(double(info.st_size)) + ", more than " + (what ? what : "such a file") +
                         " may be (at most " + size_text(double(max_bytes)) + "): is it the file meant?");
}

}  // namespace dsmplan
