// dsmplan mesh: DSM raster to the XY-3 Delaunay mesh of Adolf & Hirschmueller, Section 3 and
// Table 1 (resampled to the x/y resolution, heights in 0.1 m steps), written to a mesh file.
#include <cmath>
#include <filesystem>

#include "dsmplan/export.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"
#include "tools/job_parts.hpp"
#include "tools/report_json.hpp"

namespace dsmplan {

namespace {

// Band by band into a PLY: the raster is never held whole.
MeshReport mesh_streamed(const MeshJobOptions& options, GridSource& dsm, const Progress& progress) {
  MeshReport report;
  report.input = options.input;
  report.output = options.output;
  report.streamed = true;
  Stopwatch clock;
  const Grid& frame = dsm.frame();
  report.seconds.emplace_back("read", 0.0);
  report.seconds.emplace_back("resample", 0.0);
  PlyStreamWriter writer(options.output, frame.crs);
  const MeshStreamResult result = triangulate_xy3(dsm, writer, options.mesh, progress);
  if (result.valid_cells == 0) throw InputError(options.input, "", "no valid cell: every cell is nodata");
  require_triangles(result.triangles, frame.width, frame.height, options.input);
  writer.finish();
  report.seconds.emplace_back("triangulate", clock.lap());
  report.seconds.emplace_back("write", 0.0);
  add_total(report.seconds);
  report.vertices = result.vertices;
  report.faces = result.triangles;
  report.summary.cells = size_t(frame.width) * size_t(frame.height);
  report.summary.valid = result.valid_cells;
  report.summary.nodata = report.summary.cells - result.valid_cells;
  report.width = frame.width;
  report.height = frame.height;
  report.source_resolution = report.resolution = frame.cell_x;
  report.zstep = options.mesh.zstep;
  report.max_edge_length = max_edge_length(frame, options.mesh);
  report.file_bytes = std::filesystem::file_size(options.output);
  report.crs = frame.crs;
  return report;
}

}  // namespace

MeshReport mesh_dsm(const MeshJobOptions& options, const Progress& progress) {
  // Everything that can be checked is checked before the long work starts.
  const MeshFormat format = options.format ? *options.format : mesh_format_for(options.output);
  if (options.resolution && !(*options.resolution > 0 && std::isfinite(*options.resolution))) {
    throw ArgumentError("--res", "must be a positive number of CRS units");
  }

  check_tileset_request(options.tileset, format, options.output);
  if (options.stream && (options.resolution || format != MeshFormat::Ply))
    throw ArgumentError("--stream", "writes a .ply of the raster as it is (no --res)");
  if (!options.resolution && format == MeshFormat::Ply) {
    const std::unique_ptr<GridSource> source = open_raster(options.input, options.read);
    require_projected(source->frame().crs, options.input, centre_of(source->frame()));
    const Grid& frame = source->frame();
    const double cells = double(frame.width) * double(frame.height);
    const bool fits_whole = memory_problem(cells * (sizeof(float) + kMeshBytesPerCell)).empty();
    // A band holds about 256 rows and its halo: the streamed mode's own memory. Past 2^32 cells
    // the vertex indices may not fit: such a raster is refused by the whole-grid path's figure.
    const double band_bytes = double(frame.width) * 320 * (sizeof(float) + kMeshBytesPerCell);
    const bool can_stream = cells < 4294967295.0 && memory_problem(band_bytes).empty();
    if (options.stream && !can_stream)
      throw ArgumentError("--stream", options.input + " has " + short_number(cells) +
                                          " cells: more than 2^32 vertices or a band beyond this machine's memory");
    if (can_stream && (options.stream || !fits_whole)) return mesh_streamed(options, *source, progress);
  }
  MeshReport report;
  report.input = options.input;
  report.output = options.output;
  Stopwatch clock;
  // Without resampling the mesh's memory is known from the raster's size, before reading it.
  ReadRasterOptions read = options.read;
  if (!options.resolution) read.extra_bytes_per_cell = kMeshBytesPerCell;
  Grid dsm = read_raster(options.input, read, sub_progress(progress, 0, 0.3));
  require_projected(dsm.crs, options.input, centre_of(dsm));
  const std::optional<Wgs84Transform> tileset = tileset_heights(options.tileset, dsm.crs, options.vertical);
  report.seconds.emplace_back("read", clock.lap());
  report.source_resolution = dsm.cell_x;
  if (options.resolution && (*options.resolution != dsm.cell_x || *options.resolution != dsm.cell_y)) {
    require_memory(options.input, "--res " + short_number(*options.resolution),
                   resampled_cells(dsm.width, dsm.height, dsm.cell_x, dsm.cell_y, *options.resolution) *
                       (sizeof(float) + kMeshBytesPerCell));
    dsm = resample(dsm, *options.resolution, options.resampling, sub_progress(progress, 0.3, 0.4));
    report.resampling = options.resampling;
  }
  report.seconds.emplace_back("resample", clock.lap());
  const Mesh mesh = triangulate_xy3(dsm, options.mesh, sub_progress(progress, 0.4, 0.7));
  require_triangles(mesh.triangles.size(), dsm.width, dsm.height, options.input);
  report.seconds.emplace_back("triangulate", clock.lap());
  report.dropped_triangles =
      write_mesh_output(mesh, options.output, format, tileset, report.tileset, sub_progress(progress, 0.7, 1.0));
  report.seconds.emplace_back("write", clock.lap());
  add_total(report.seconds);

  report.vertices = mesh.vertices.size();
  report.faces = mesh.triangles.size();
  report.summary = summarize(dsm);
  report.width = dsm.width;
  report.height = dsm.height;
  report.resolution = dsm.cell_x;
  report.zstep = options.mesh.zstep;
  report.max_edge_length = max_edge_length(dsm, options.mesh);
  report.file_bytes = std::filesystem::file_size(options.output);
  report.crs = mesh.crs;
  return report;
}

Json to_json(const MeshReport& report) {
  return {{"input", report.input},
          {"output", report.output},
          {"vertices", report.vertices},
          {"faces", report.faces},
          {"cells", report.summary.cells},
          {"valid_cells", report.summary.valid},
          {"nodata_cells", report.summary.nodata},
          {"holes", report.streamed ? Json(nullptr) : Json(report.summary.holes)},
          {"width", report.width},
          {"height", report.height},
          {"source_resolution", report.source_resolution},
          {"resolution", report.resolution},
          {"resampling", report.resampling ? to_string(*report.resampling) : "none"},
          {"zstep", report.zstep},
          {"max_edge_length", report.max_edge_length},
          {"file_bytes", report.file_bytes},
          {"dropped_triangles", report.dropped_triangles},
          {"crs", crs_json(report.crs)},
          {"vertical", vertical_json(report.crs)},
          {"seconds", seconds_json(report.seconds)},
          {"streamed", report.streamed},
          {"tileset", tileset_report_json(report.tileset)}};
}

}  // namespace dsmplan
