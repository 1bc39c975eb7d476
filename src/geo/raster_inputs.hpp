// What every raster reader of src/geo asks of a file before GDAL opens it (gdal_io.cpp,
// image_file.cpp, rpc_reader.cpp).
#pragma once

#include <string>

namespace dsmplan {

/// require_input_file() (core) for `path` and, when it is a VRT, for every file it names
/// (SourceFilename, SourceDataset; relative to the VRT where it says so; nested VRTs to a depth
/// of 8): GDAL opens a VRT's sources itself, and one that is a FIFO would hold it forever.
/// InputError naming the file at fault. Reads the VRT's XML only (a few kB); GDAL's virtual file
/// systems (/vsi...) and inline XML are left to GDAL.
void require_raster_files(const std::string& path);

}  // namespace dsmplan
