// dsmplan/tools.hpp: the command-line tools as library functions, as GDAL's gdal_utils.h.
//
// Each tool takes an options struct, does the whole job (reading, every stage, writing, with
// progress) and returns a report. to_json() of a report is exactly what `dsmplan ... --json`
// prints or `--stats` writes: its keys are a contract with users and other tools, so keys are
// added, never renamed. The dsmplan binary does nothing but parse argv into these structs.
//
// Errors: as in core.hpp. Every option is checked before any long work starts.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

using Json = nlohmann::ordered_json;

// ---- dsmplan info ---------------------------------------------------------------------------

struct InfoOptions {
  std::string input;
  ReadRasterOptions read;  ///< a raster without CRS is described, not refused
};

struct RasterReport {
  std::string input;
  int width = 0, height = 0;
  double cell_x = 0, cell_y = 0;
  double xmin = 0, ymin = 0, xmax = 0, ymax = 0;  ///< outer edges of the cells, CRS units
  Crs crs;
  GridSummary summary;
};

RasterReport describe_raster(const InfoOptions& options);
/// Keys: file, width, height, resolution [x,y], extent {xmin,ymin,xmax,ymax}, crs {name,epsg,wkt},
/// vertical {name,unit}, cells, valid_cells, nodata_cells, holes, height_range [min,max].
Json to_json(const RasterReport& report);
/// The same for people, one "Label: value" line each.
std::string to_text(const RasterReport& report);

// ---- dsmplan grid ---------------------------------------------------------------------------

struct GridOptions {
  std::vector<std::string> inputs;  ///< LAS or XYZ files, all in one CRS
  std::string output;               ///< GeoTIFF (.tif, .tiff)
  std::string crs;                  ///< overrides the files' CRS; required when they have none
  GridPointsOptions grid;
  double fill_distance = 0;  ///< > 0: fill holes up to this distance (CRS units) from data
};

/// Reads the point clouds, grids them (median or max per cell), optionally fills holes, writes
/// the GeoTIFF atomically. Returns the written grid's summary.
GridSummary grid_to_geotiff(const GridOptions& options, const Progress& progress = {});

// ---- dsmplan mesh ---------------------------------------------------------------------------

struct MeshJobOptions {
  std::string input;   ///< DSM raster
  std::string output;  ///< .ply, .obj or .off
  ReadRasterOptions read;
  std::optional<double> resolution;  ///< resample to this x/y cell size first; none: keep the DSM's
  Resampling resampling = Resampling::Median;
  MeshOptions mesh;
};

struct MeshReport {
  std::string input, output;
  size_t vertices = 0, faces = 0;
  GridSummary summary;  ///< of the DSM as meshed (after resampling)
  int width = 0, height = 0;
  double source_resolution = 0, resolution = 0;
  std::optional<Resampling> resampling;  ///< none when the DSM was meshed at its own resolution
  double zstep = 0, max_edge_length = 0;
  uint64_t file_bytes = 0;
  Crs crs;
  std::vector<std::pair<std::string, double>> seconds;  ///< read, resample, triangulate, write, total
};

/// DSM raster -> resampled, quantized grid -> XY-3 Delaunay mesh -> mesh file. Refuses
/// geographic CRSs (x,y in degrees cannot carry a metric safety distance).
MeshReport mesh_dsm(const MeshJobOptions& options, const Progress& progress = {});
/// Keys: input, output, vertices, faces, cells, valid_cells, nodata_cells, holes, width, height,
/// source_resolution, resolution, resampling, zstep, max_edge_length, file_bytes, crs, vertical,
/// seconds {read, resample, triangulate, write, total}.
Json to_json(const MeshReport& report);

}  // namespace dsmplan
