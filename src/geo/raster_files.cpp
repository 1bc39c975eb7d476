// The files behind a raster (dsmplan/raster_io.hpp, raster_file_list()): what a run reads when
// it reads a VRT mosaic, for the job layer's check that no output replaces an input.
#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal_priv.h>

#include "dsmplan/raster_io.hpp"

namespace dsmplan {

std::vector<std::string> raster_file_list(const std::string& path) {
  GDALAllRegister();
  CPLPushErrorHandler(CPLQuietErrorHandler);  // a broken raster is the reader's to report, once
  std::unique_ptr<GDALDataset> dataset(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  CPLPopErrorHandler();
  std::vector<std::string> files;
  if (!dataset) return files;
  const CPLStringList list(dataset->GetFileList());
  for (int k = 0; k < list.size(); ++k) files.push_back(list[k]);
  return files;
}

}  // namespace dsmplan
