// The files of one run kept apart: no output may replace an input or another output.
#include <sys/stat.h>

#include <filesystem>
#include <string>
#include <vector>

#include "dsmplan/tools.hpp"

namespace dsmplan {

namespace {

// True when a and b name the same file: by device and inode when both exist (hard links,
// symbolic links, bind mounts), else by their absolute paths with "..", "." and the symbolic
// links of the existing part resolved.
bool same_file(const std::string& a, const std::string& b) {
  struct stat sa, sb;
  if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  std::error_code ea, eb;
  const std::filesystem::path pa = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
  const std::filesystem::path pb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
  return !ea && !eb && pa == pb;
}

}  // namespace

void refuse_overwrites(const std::vector<NamedFile>& inputs, const std::vector<NamedFile>& outputs) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    const NamedFile& out = outputs[i];
    if (out.path.empty()) continue;
    auto refuse = [&](const NamedFile& other, const char* role) {
      throw ArgumentError(out.flag, "'" + out.path + "' is the same file as " + other.flag + " '" + other.path +
                                        "' (" + role + "): an output never replaces what the run reads or writes");
    };
    for (const NamedFile& in : inputs)
      if (!in.path.empty() && same_file(out.path, in.path)) refuse(in, "an input");
    for (size_t j = 0; j < i; ++j)
      if (!outputs[j].path.empty() && same_file(out.path, outputs[j].path)) refuse(outputs[j], "another output");
  }
}

}  // namespace dsmplan
