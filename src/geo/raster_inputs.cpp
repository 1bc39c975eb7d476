// require_raster_files(): a VRT's sources are inputs too. GDAL opens them with open(), which waits
// forever on a FIFO with no writer (issue 33, point 2), so they are asked what they are first.
// The XML is read with GDAL's own parser (CPLParseXMLFile), as GDAL's VRT driver reads it
// (frmts/vrt/vrtsources.cpp: SourceFilename and its relativeToVRT attribute).
#include "raster_inputs.hpp"

#include <cpl_minixml.h>
#include <cpl_string.h>

#include <cstdio>
#include <cstring>
#include <memory>

#include "dsmplan/core.hpp"

namespace dsmplan {

namespace {

constexpr int kMaxDepth = 8;  // VRTs naming VRTs: deeper is a loop, or no file anyone writes

bool is_vrt(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) return false;
  char head[256] = {};
  const size_t n = std::fread(head, 1, sizeof head - 1, file.get());
  head[n] = 0;
  return std::strstr(head, "<VRTDataset") != nullptr;
}

void require_sources(const CPLXMLNode* node, const std::string& vrt, int depth);

void require_file(const std::string& path, int depth) {
  require_input_file(path);
  if (depth >= kMaxDepth || !is_vrt(path)) return;
  std::unique_ptr<CPLXMLNode, void (*)(CPLXMLNode*)> tree(CPLParseXMLFile(path.c_str()), &CPLDestroyXMLNode);
  if (tree) require_sources(tree.get(), path, depth + 1);
}

void require_sources(const CPLXMLNode* node, const std::string& vrt, int depth) {
  for (; node; node = node->psNext) {
    if (node->eType != CXT_Element) continue;
    if (EQUAL(node->pszValue, "SourceFilename") || EQUAL(node->pszValue, "SourceDataset")) {
      const std::string name = CPLGetXMLValue(node, nullptr, "");
      const bool relative = EQUAL(CPLGetXMLValue(node, "relativeToVRT", "0"), "1");
      if (!name.empty() && name[0] != '<' && !STARTS_WITH_CI(name.c_str(), "/vsi"))
        require_file(relative ? CPLProjectRelativeFilename(CPLGetPath(vrt.c_str()), name.c_str()) : name, depth);
    }
    require_sources(node->psChild, vrt, depth);
  }
}

}  // namespace

void require_raster_files(const std::string& path) { require_file(path, 0); }

}  // namespace dsmplan
