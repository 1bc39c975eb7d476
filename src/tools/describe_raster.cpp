// dsmplan info: what a DSM raster holds, read through GDAL.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "dsmplan/rpc_io.hpp"
#include "dsmplan/tools.hpp"
#include "tools/report_json.hpp"

namespace dsmplan {

namespace {

// "US survey foot (0.3048006 m)", "metre", "degree", "furlong (not a length dsmplan knows)".
std::string unit_text(const std::string& unit, double metres) {
  if (metres == 1 || unit == "degree") return unit;
  if (!(metres > 0)) return unit + " (not a length unit dsmplan knows)";
  char text[48];
  std::snprintf(text, sizeof text, " (%.7g m)", metres);
  return unit + text;
}

// What `info --json` adds to "crs" and "vertical": metres per unit (null when not known).
Json units_json(const Crs& crs) {
  auto metres = [](double m) { return m > 0 ? Json(m) : Json(nullptr); };
  return {{"horizontal", crs.linear_unit.empty() ? Json(nullptr) : Json(crs.linear_unit)},
          {"horizontal_m", metres(crs.linear_unit_m)},
          {"vertical", crs.vertical_unit.empty() ? Json(nullptr) : Json(crs.vertical_unit)},
          {"vertical_m", metres(crs.vertical_unit_m)}};
}

Json rpc_json(const RasterReport& report) {
  if (!report.rpc) return nullptr;
  const RasterReport::Rpc& rpc = *report.rpc;
  Json corners = Json::array();
  for (const GeoPoint& c : rpc.corners) corners.push_back({c.lon, c.lat});
  return {{"source", rpc.source},
          {"sensor_offset", {rpc.sensor_col, rpc.sensor_row}},
          {"height_range", {rpc.height_min, rpc.height_max}},
          {"footprint", {{"height", rpc.footprint_height}, {"corners", corners}}}};
}

}  // namespace

InfoFormat parse_info_format(const std::string& name) {
  if (name.empty() || name == "text") return InfoFormat::Text;
  if (name == "json") return InfoFormat::Json;
  throw ArgumentError("--of", "info prints text or json, got '" + name + "'");
}

RasterReport describe_raster(const InfoOptions& options) {
  ReadRasterOptions read = options.read;
  read.allow_no_crs = true;       // info describes what is there, CRS or not,
  read.allow_other_units = true;  // and in whatever unit
  const Grid grid = read_raster(options.input, read);
  RasterReport report;
  report.input = options.input;
  report.width = grid.width;
  report.height = grid.height;
  report.cell_x = grid.cell_x;
  report.cell_y = grid.cell_y;
  report.xmin = grid.x0;
  report.xmax = grid.x1();
  report.ymin = grid.y1();
  report.ymax = grid.y0;
  report.crs = grid.crs;
  report.summary = summarize(grid);
  if (has_rpc(options.input)) {
    const RpcCamera camera = read_rpc_camera(options.input);
    const RpcModel& m = camera.model();
    RasterReport::Rpc rpc;
    const auto geom = std::filesystem::path(options.input).replace_extension(".geom");
    rpc.source = std::filesystem::exists(geom) ? geom.string() : "GDAL RPC metadata";
    rpc.sensor_col = camera.sensor_col();
    rpc.sensor_row = camera.sensor_row();
    rpc.height_min = m.height_off - std::abs(m.height_scale);
    rpc.height_max = m.height_off + std::abs(m.height_scale);
    rpc.footprint_height = m.height_off;
    const double w = grid.width, h = grid.height;
    const PixelPoint corners[4] = {{0, 0}, {w, 0}, {w, h}, {0, h}};
    for (int i = 0; i < 4; ++i) rpc.corners[i] = camera.localize(corners[i], m.height_off);
    report.rpc = rpc;
  }
  return report;
}

Json to_json(const RasterReport& report) {
  const GridSummary& summary = report.summary;
  return {{"file", report.input},
          {"width", report.width},
          {"height", report.height},
          {"resolution", {report.cell_x, report.cell_y}},
          {"extent", {{"xmin", report.xmin}, {"ymin", report.ymin}, {"xmax", report.xmax}, {"ymax", report.ymax}}},
          {"crs", crs_json(report.crs)},
          {"vertical", vertical_json(report.crs)},
          {"units", units_json(report.crs)},
          {"cells", summary.cells},
          {"valid_cells", summary.valid},
          {"nodata_cells", summary.nodata},
          {"holes", summary.holes},
          {"height_range", {as_stored(summary.z_min), as_stored(summary.z_max)}},
          {"rpc", rpc_json(report)}};
}

std::string to_text(const RasterReport& report) {
  const Crs& crs = report.crs;
  const GridSummary& summary = report.summary;
  std::string crs_text = crs.name.empty() ? "none" : crs.name;
  if (crs.epsg) crs_text += " (EPSG:" + std::to_string(crs.epsg) + ")";
  if (!crs.linear_unit.empty()) crs_text += ", unit " + unit_text(crs.linear_unit, crs.linear_unit_m);
  const std::string vertical =
      (crs.vertical_name.empty() ? "datum unknown" : crs.vertical_name) +
      (crs.vertical_unit.empty() ? ", unit unknown" : ", unit " + unit_text(crs.vertical_unit, crs.vertical_unit_m));
  char text[2048];
  std::snprintf(text, sizeof text,
                "File:        %s\n"
                "Size:        %d x %d cells\n"
                "Resolution:  %.10g x %.10g\n"
                "Extent:      x %.10g .. %.10g, y %.10g .. %.10g\n"
                "CRS:         %s\n"
                "Vertical:    %s\n"
                "Nodata:      %zu of %zu cells (%zu holes)\n"
                "Heights:     %.10g .. %.10g\n",
                report.input.c_str(), report.width, report.height, report.cell_x, report.cell_y, report.xmin,
                report.xmax, report.ymin, report.ymax, crs_text.c_str(), vertical.c_str(), summary.nodata,
                summary.cells, summary.holes, as_stored(summary.z_min), as_stored(summary.z_max));
  std::string out = text;
  if (report.rpc) {
    const RasterReport::Rpc& rpc = *report.rpc;
    double lon0 = 1e9, lon1 = -1e9, lat0 = 1e9, lat1 = -1e9;
    for (const GeoPoint& c : rpc.corners)
      lon0 = std::min(lon0, c.lon), lon1 = std::max(lon1, c.lon), lat0 = std::min(lat0, c.lat),
      lat1 = std::max(lat1, c.lat);
    std::snprintf(text, sizeof text,
                  "RPC:         from %s, sensor offset %.10g %.10g px, heights %.10g .. %.10g m (WGS 84 ellipsoid)\n"
                  "Footprint:   lon %.6f .. %.6f, lat %.6f .. %.6f (corners at %.10g m)\n",
                  rpc.source.c_str(), rpc.sensor_col, rpc.sensor_row, rpc.height_min, rpc.height_max, lon0, lon1, lat0,
                  lat1, rpc.footprint_height);
    out += text;
  }
  return out;
}

}  // namespace dsmplan
