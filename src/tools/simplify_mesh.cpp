// dsmplan simplify: a DSM (meshed first, as `dsmplan mesh` does) or a mesh file, simplified by
// the paper's variant one or two (Adolf & Hirschmueller, Section 4 and Table 2) or by the
// bounded mode, and certified against the DSM at every valid cell centre.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "dsmplan/export.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"
#include "tools/job_parts.hpp"
#include "tools/report_json.hpp"

namespace dsmplan {

namespace {

// `bytes_per_cell`: what the job will need per cell of the (resampled) DSM, refused up front
// when the machine has less.
Grid read_dsm(const std::string& path, const SimplifyJobOptions& options, double bytes_per_cell, SimplifyReport& report,
              const Progress& progress) {
  ReadRasterOptions read = options.read;
  if (!options.resolution) read.extra_bytes_per_cell = bytes_per_cell;
  Grid dsm = read_raster(path, read, progress);
  require_projected(dsm.crs, path, centre_of(dsm));
  report.source_resolution = dsm.cell_x;
  if (options.resolution && (*options.resolution != dsm.cell_x || *options.resolution != dsm.cell_y)) {
    require_memory(path, "--res " + short_number(*options.resolution),
                   resampled_cells(dsm.width, dsm.height, dsm.cell_x, dsm.cell_y, *options.resolution) *
                       (sizeof(float) + bytes_per_cell));
    dsm = resample(dsm, *options.resolution, options.resampling);
  }
  report.resolution = dsm.cell_x;
  return dsm;
}

SimplifyReport start_report(const SimplifyJobOptions& options) {
  SimplifyReport report;
  report.input = options.input;
  report.output = options.output;
  report.method = options.chosen_method();
  report.paper = options.paper_options();
  report.bounded = options.bounded_options();
  return report;
}

MeshFormat output_format(const SimplifyJobOptions& options) {
  return options.format ? *options.format : mesh_format_for(options.output);
}

// The bounded mode on the DSM as it is: read window by window and written block by block, so
// any raster or VRT mosaic fits in memory (see "out of core" in simplify.hpp). PLY is written
// as it comes; the other formats need the whole mesh in memory.
SimplifyReport simplify_streamed(const SimplifyJobOptions& options, MeshFormat format, const Progress& progress) {
  SimplifyReport report = start_report(options);
  Stopwatch clock;
  const std::unique_ptr<GridSource> dsm = open_raster(options.input, options.read);
  const Grid& frame = dsm->frame();
  require_projected(frame.crs, options.input, centre_of(frame));
  report.source_resolution = report.resolution = frame.cell_x;
  report.crs = frame.crs;
  const std::optional<Wgs84Transform> tileset = tileset_heights(options.tileset, frame.crs, options.vertical);
  report.seconds.emplace_back("read", clock.lap());
  report.seconds.emplace_back("mesh", 0.0);
  const Progress simplify_progress = sub_progress(progress, 0, format == MeshFormat::Ply ? 1.0 : 0.8);
  auto simplify = [&](MeshSink& sink) {
    return options.bounded_engine ? options.bounded_engine(*dsm, report.bounded, sink, simplify_progress)
                                  : simplify_bounded(*dsm, report.bounded, sink, simplify_progress);
  };
  BoundedStreamResult result;
  if (format == MeshFormat::Ply) {
    PlyStreamWriter writer(options.output, frame.crs);
    result = simplify(writer);
    require_triangles(result.triangles, frame.width, frame.height, options.input);
    writer.finish();
    // Reading, simplifying, certifying and writing are one pass here: all under "simplify".
    report.seconds.emplace_back("simplify", clock.lap());
    report.seconds.emplace_back("certify", 0.0);
    report.seconds.emplace_back("write", 0.0);
  } else {
    require_memory(options.input, std::to_string(frame.width) + " x " + std::to_string(frame.height) + " cells",
                   double(frame.width) * double(frame.height) * kBoundedBytesPerCell);
    Mesh output;
    output.crs = frame.crs;
    MeshCollector collector(output);
    result = simplify(collector);
    report.seconds.emplace_back("simplify", clock.lap());
    report.seconds.emplace_back("certify", 0.0);
    require_triangles(output.triangles.size(), frame.width, frame.height, options.input);
    report.dropped_triangles =
        write_mesh_output(output, options.output, format, tileset, report.tileset, sub_progress(progress, 0.8, 1.0));
    report.seconds.emplace_back("write", clock.lap());
  }
  add_total(report.seconds);
  report.vertices_in = result.valid_cells;
  report.faces_in = 0;
  report.vertices_out = result.vertices;
  report.faces_out = result.triangles;
  report.error = result.error;
  return report;
}

}  // namespace

const char* to_string(SimplifyMethod method) {
  switch (method) {
    case SimplifyMethod::Variant1:
      return "variant1";
    case SimplifyMethod::Variant2:
      return "variant2";
    case SimplifyMethod::Bounded:
      return "bounded";
  }
  return "?";
}

SimplifyMethod parse_simplify_method(const std::string& name) {
  for (SimplifyMethod method : {SimplifyMethod::Variant1, SimplifyMethod::Variant2, SimplifyMethod::Bounded})
    if (name == to_string(method)) return method;
  require_choice("--method", name, {"variant1", "variant2", "bounded"});
  return SimplifyMethod::Bounded;  // not reached: require_choice() threw
}

void SimplifyJobOptions::check() const {
  // A parameter of the other method would be ignored without a word: refused, by its flag.
  const std::string not_method = "not --method " + std::string(to_string(chosen_method()));
  if (max_error && method && *method != SimplifyMethod::Bounded)
    throw ArgumentError("--max-error", "belongs to the bounded mode, " + not_method);
  const bool bounded = chosen_method() == SimplifyMethod::Bounded;
  if (!bounded && conservative) throw ArgumentError("--conservative", "belongs to the bounded mode, " + not_method);
  for (const auto& [flag, tolerance] : {std::pair{"--dz", dz}, std::pair{"--dco", dco}})
    if (bounded && tolerance)
      throw ArgumentError(flag,
                          "belongs to the paper's variants (--method variant1|variant2); the "
                          "bounded mode (the default) is bounded by --max-error");
  const MeshFormat format = output_format(*this);
  if (resolution && !(*resolution > 0 && std::isfinite(*resolution))) {
    throw ArgumentError("--res", "must be a positive number of CRS units");
  }
  if (bounded) {
    check_bounded_options(bounded_options());
  } else {
    check_paper_options(paper_options());
  }
  check_tileset_request(tileset, format, output);
}

BoundedSimplifyOptions SimplifyJobOptions::bounded_options() const {
  BoundedSimplifyOptions options;
  // Without --max-error, the safe default; --max-error E alone keeps its meaning: |mesh - DSM| <= E.
  options.max_error = max_error.value_or(options.max_error);
  options.conservative = conservative || !max_error;
  options.delaunay = delaunay;
  options.tile_size = tile_size;
  options.block_tiles = block_tiles;
  options.threads = threads;
  return options;
}

PaperSimplifyOptions SimplifyJobOptions::paper_options() const {
  PaperSimplifyOptions options;
  options.variant = chosen_method() == SimplifyMethod::Variant1 ? PaperVariant::One : PaperVariant::Two;
  options.dz = dz.value_or(options.dz);
  options.dco = dco.value_or(options.dco);
  return options;
}

SimplifyReport simplify_job(const SimplifyJobOptions& options, const Progress& progress) {
  // Everything that can be checked is checked before the long work starts.
  options.check();
  const MeshFormat format = output_format(options);
  const bool bounded = options.chosen_method() == SimplifyMethod::Bounded;
  const bool mesh_input = is_mesh_file(options.input);
  if (mesh_input && options.dsm.empty()) {
    throw ArgumentError("--dsm", options.input +
                                     " is a mesh: the certified error needs the DSM it was made from; "
                                     "pass --dsm DSM (with the same --res)");
  }
  if (mesh_input && bounded) {
    throw ArgumentError("--method", "the bounded mode (the default) works on the DSM grid: give the DSM (" +
                                        options.dsm + ") as the input instead of the mesh " + options.input +
                                        ", or --method variant1|variant2 for the paper's simplification of the mesh");
  }

  if (bounded && !mesh_input && !options.resolution) return simplify_streamed(options, format, progress);

  SimplifyReport report = start_report(options);
  Stopwatch clock;
  Grid dsm;
  Mesh input;
  if (mesh_input) {
    input = read_mesh(options.input, sub_progress(progress, 0, 0.1));
    check_2_5d(input, options.input);
    require_projected(input.crs, options.input, centre_of(input));
    dsm = read_dsm(options.dsm, options, kPaperSimplifyBytesPerCell, report, sub_progress(progress, 0.1, 0.2));
    if (input.crs.epsg && dsm.crs.epsg && input.crs.epsg != dsm.crs.epsg) {
      throw InputError(options.input, "",
                       "CRS EPSG:" + std::to_string(input.crs.epsg) +
                           " differs from the DSM's EPSG:" + std::to_string(dsm.crs.epsg) + " (" + options.dsm + ")");
    }
    if (input.crs.wkt.empty()) input.crs = dsm.crs;
    report.seconds.emplace_back("read", clock.lap());
  } else {
    dsm = read_dsm(options.input, options, bounded ? kBoundedBytesPerCell : kPaperSimplifyBytesPerCell, report,
                   sub_progress(progress, 0, 0.15));
    report.seconds.emplace_back("read", clock.lap());
    if (!bounded) input = triangulate_xy3(dsm, options.mesh, sub_progress(progress, 0.15, 0.2));
    report.seconds.emplace_back("mesh", clock.lap());
  }
  const std::optional<Wgs84Transform> tileset =
      tileset_heights(options.tileset, mesh_input ? input.crs : dsm.crs, options.vertical);
  report.vertices_in = bounded ? summarize(dsm).valid : input.vertices.size();
  report.faces_in = bounded ? 0 : input.triangles.size();

  Mesh output;
  const Progress simplify_progress = sub_progress(progress, 0.2, 0.8);
  if (bounded) {
    GridView view(dsm);
    output.crs = dsm.crs;
    MeshCollector collector(output);
    report.error = simplify_bounded(view, report.bounded, collector, simplify_progress).error;
    report.seconds.emplace_back("simplify", clock.lap());
  } else {
    PaperSimplifyResult result = simplify_paper(input, report.paper, simplify_progress);
    report.removed_coplanar = result.removed_coplanar;
    report.removed_colinear = result.removed_colinear;
    report.restored_colinear = result.restored_colinear;
    output = std::move(result.mesh);
    clock.lap();
    report.seconds.emplace_back("search", result.seconds_search);
    report.seconds.emplace_back("triangulate", result.seconds_triangulate);
  }
  input = Mesh();
  require_triangles(output.triangles.size(), dsm.width, dsm.height, mesh_input ? options.dsm : options.input);
  // The bounded mode certified its blocks as it made them (certify() on every tile).
  if (!bounded) report.error = certify(output, dsm, sub_progress(progress, 0.8, 0.9));
  report.seconds.emplace_back("certify", clock.lap());
  report.dropped_triangles =
      write_mesh_output(output, options.output, format, tileset, report.tileset, sub_progress(progress, 0.9, 1.0));
  report.seconds.emplace_back("write", clock.lap());
  add_total(report.seconds);
  report.vertices_out = output.vertices.size();
  report.faces_out = output.triangles.size();
  report.crs = output.crs;
  return report;
}

Json to_json(const SimplifyReport& report) {
  auto count_or_null = [](const std::optional<size_t>& n) { return n ? Json(*n) : Json(nullptr); };
  const bool bounded = report.method == SimplifyMethod::Bounded;
  const double kept = report.vertices_in ? double(report.vertices_out) / double(report.vertices_in) : 0;
  return {{"input", report.input},
          {"output", report.output},
          {"method", to_string(report.method)},
          {"dz", bounded ? Json(nullptr) : Json(report.paper.dz)},
          {"dco", bounded ? Json(nullptr) : Json(report.paper.dco)},
          {"max_error", bounded ? Json(report.bounded.max_error) : Json(nullptr)},
          {"conservative", bounded && report.bounded.conservative},
          {"delaunay", !bounded || report.bounded.delaunay},
          {"source_resolution", report.source_resolution},
          {"resolution", report.resolution},
          {"vertices_in", report.vertices_in},
          {"vertices_out", report.vertices_out},
          {"reduction", 1 - kept},
          {"removed_coplanar", count_or_null(report.removed_coplanar)},
          {"removed_colinear", count_or_null(report.removed_colinear)},
          {"restored_colinear", count_or_null(report.restored_colinear)},
          {"faces_in", report.faces_in ? Json(report.faces_in) : Json(nullptr)},
          {"faces_out", report.faces_out},
          {"max_above_m", report.error.max_above},
          {"max_below_m", report.error.max_below},
          {"rms_m", report.error.rms},
          {"certified_cells", report.error.cells},
          {"uncovered_cells", report.error.uncovered},
          {"dropped_triangles", report.dropped_triangles},
          {"crs", crs_json(report.crs)},
          {"vertical", vertical_json(report.crs)},
          {"seconds", seconds_json(report.seconds)},
          {"tileset", tileset_report_json(report.tileset)}};
}

std::string to_text(const SimplifyReport& report) {
  char line[512];
  const double reduction =
      report.vertices_in ? 100.0 * (1 - double(report.vertices_out) / double(report.vertices_in)) : 0;
  double total = 0;
  for (const auto& [stage, seconds] : report.seconds)
    if (stage == "total") total = seconds;
  std::string removed;
  if (report.removed_coplanar) {
    removed = ", co-planar " + std::to_string(*report.removed_coplanar) + ", co-linear " +
              std::to_string(report.removed_colinear.value_or(0));
  }
  std::snprintf(line, sizeof line,
                "%s: %zu -> %zu vertices (-%.1f%%)%s, %zu faces; certified error: mesh up to %.3f m above and "
                "%.3f m below the DSM (rms %.3f m) at %zu cells%s; %.2f s\n",
                to_string(report.method), report.vertices_in, report.vertices_out, reduction, removed.c_str(),
                report.faces_out, report.error.max_above, report.error.max_below, report.error.rms, report.error.cells,
                report.error.uncovered ? (", " + std::to_string(report.error.uncovered) + " uncovered").c_str() : "",
                total);
  return line;
}

}  // namespace dsmplan
