// The files of one run kept apart: no output may replace an input or another output.
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "dsmplan/raster_io.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

namespace {

// True when a and b name the same file: by device and inode when both exist (hard links,
// symbolic links, bind mounts), else by their absolute paths with "..", "." and the symbolic
// links of the existing part resolved.
bool same_file(const std::string& a, const std::string& b) {
  struct stat sa, sb;
  if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0)
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  std::error_code ea, eb;
  const std::filesystem::path pa = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
  const std::filesystem::path pb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
  return !ea && !eb && pa == pb;
}

// A VRT mosaic reads its source rasters: they are inputs too, named "<flag>'s source".
std::vector<NamedFile> with_vrt_sources(const std::vector<NamedFile>& inputs) {
  std::vector<NamedFile> all = inputs;
  for (const NamedFile& in : inputs) {
    std::string extension = std::filesystem::path(in.path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (extension != ".vrt") continue;
    require_input_file(in.path);  // GDAL would wait forever on a FIFO
    for (const std::string& file : raster_file_list(in.path)) all.push_back({in.flag + "'s source", file});
  }
  return all;
}

}  // namespace

void refuse_overwrites(const std::vector<NamedFile>& given_inputs, const std::vector<NamedFile>& outputs) {
  const std::vector<NamedFile> inputs = with_vrt_sources(given_inputs);
  for (size_t i = 0; i < outputs.size(); ++i) {
    const NamedFile& out = outputs[i];
    if (out.path.empty()) continue;
    auto refuse = [&](const NamedFile& other, const char* role) {
      throw ArgumentError(out.flag, "'" + out.path + "' is the same file as " + other.flag + " '" + other.path + "' (" +
                                        role + "): an output never replaces what the run reads or writes");
    };
    for (const NamedFile& in : inputs)
      if (!in.path.empty() && same_file(out.path, in.path)) refuse(in, "an input");
    for (size_t j = 0; j < i; ++j)
      if (!outputs[j].path.empty() && same_file(out.path, outputs[j].path)) refuse(outputs[j], "another output");
  }
}

}  // namespace dsmplan
