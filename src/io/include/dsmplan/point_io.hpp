// dsmplan/point_io.hpp: the point-cloud files of stage 1 (LAS, LAZ, XYZ) read into PointCloud
// (points.hpp), which grid_points() turns into a DSM. Errors: InputError naming the file and the
// place (byte offset, header field, line); see core.hpp.
#pragma once

#include <string>

#include "dsmplan/core.hpp"
#include "dsmplan/points.hpp"

namespace dsmplan {

/// Reads a LAS 1.0-1.4 file, point formats 0-10, or a LAZ file (LASzip-compressed formats 0-3
/// and 6-8, decoded by dsmplan's own decoder on all cores: dsmplan/laz.hpp) into the same points.
/// Checks the header against the file (signature, sizes, point count x record length <= file
/// size, scale factors; for LAZ the VLR and chunk table); a header that lies gives InputError
/// naming the field. CRS from the OGC WKT VLR/EVLR (record 2112) or the GeoTIFF key directory
/// (record 34735, EPSG codes only). O(points).
PointCloud read_las(const std::string& path, const Progress& progress = {});

/// Reads "x y z [class]" text lines (separators: blanks, comma, semicolon). Blank lines and
/// lines starting with '#' are skipped, as is a first line without any digit (a column header).
/// A line that does not parse gives InputError with its line number. No CRS.
PointCloud read_xyz(const std::string& path, const Progress& progress = {});

/// read_las or read_xyz by extension (.las / .xyz, .txt, .csv); InputError for anything else.
PointCloud read_points(const std::string& path, const Progress& progress = {});

}  // namespace dsmplan
