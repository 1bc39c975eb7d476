// dsmplan stereo: stereo_job() for frame cameras (--cameras), satellite_stereo_job() for images
// with RPCs. Its checks stay here for now: the stereo stage is taking them over (issue 32).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <tuple>

#include "command.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/satellite_stereo_job.hpp"
#include "dsmplan/stereo_job.hpp"

namespace dsmplan::cli {

namespace {

// What the command line gives, before the checks.
struct Request {
  StereoJobOptions stereo;
  SatelliteStereoOptions satellite;
  std::string bounds, stats;
  double fusion_memory_mb = 1024, band_memory_mb = 1024;
};

// The checks as they were in apps/dsmplan.cpp (the stereo stage is taking them over), then
// the frame or the satellite pipeline.
void run(Request& request, bool quiet) {
  StereoJobOptions& stereo = request.stereo;
  SatelliteStereoOptions& satellite = request.satellite;
  const std::string& stereo_bounds = request.bounds;
  const std::string& stereo_stats = request.stats;
  const double fusion_memory_mb = request.fusion_memory_mb, band_memory_mb = request.band_memory_mb;
  if (!stereo_bounds.empty()) {
    try {
      const Window w = parse_window(stereo_bounds);
      stereo.bounds = std::array<double, 4>{w.xmin, w.ymin, w.xmax, w.ymax};
    } catch (const ArgumentError&) {
      throw ArgumentError("--bounds", "expected four numbers x0,y0,x1,y1, got '" + stereo_bounds.substr(0, 80) + "'");
    }
  }
  if (stereo.cameras.empty() == satellite.images.empty())
    throw ArgumentError("--cameras",
                        "give either satellite images with RPCs (dsmplan stereo IMG1 IMG2 ...) or "
                        "--cameras CAMERAS.json for frame cameras, not both");
  for (const auto& [flag, megabytes, least] :
       {std::tuple{"--fusion-memory", fusion_memory_mb, 0.0625}, std::tuple{"--band-memory", band_memory_mb, 1.0}})
    if (!(megabytes >= least && megabytes < 1e9)) {
      char range[96];  // %g: 1e300 as typed, not as 301 digits
      std::snprintf(range, sizeof range, "must lie in [%g, 1e9) MB, got %g", least, megabytes);
      throw ArgumentError(flag, range);
    }
  stereo.band_memory_bytes = static_cast<std::size_t>(band_memory_mb * 1048576.0);
  stereo.fusion_memory_bytes = satellite.fusion_memory_bytes = static_cast<std::size_t>(fusion_memory_mb * 1048576.0);
  if (!stereo.cameras.empty()) {
    if (!satellite.crs.empty())
      throw ArgumentError("--crs", "belongs to satellite images; CAMERAS.json states its CRS");
    if (satellite.allow_approximate_vertical)
      throw ArgumentError("--allow-approximate-vertical", "belongs to satellite images with a compound --crs");
    refuse_overwrites(stereo_job_inputs(stereo), {{"-o", stereo.output}, {"--stats", stereo_stats}});
    if (!stereo_stats.empty()) check_writable(stereo_stats);
    const StereoReport report = stereo_job(stereo, terminal_progress(quiet));
    write_stats(stereo_stats, to_json(report), {stereo.output});
  } else {
    if (stereo.pairs != "auto")
      throw ArgumentError("--pairs", "belongs to --cameras; satellite images are paired by overlap");
    satellite.output = stereo.output;
    satellite.resolution = stereo.resolution;
    satellite.bounds = stereo.bounds;
    std::vector<NamedFile> inputs;
    for (const std::string& image : satellite.images) {
      inputs.push_back({"IMAGES", image});
      const std::string geom = std::filesystem::path(image).replace_extension(".geom").string();
      if (std::filesystem::exists(geom)) inputs.push_back({"IMAGES", geom});
    }
    refuse_overwrites(inputs, {{"-o", satellite.output}, {"--stats", stereo_stats}});
    if (!stereo_stats.empty()) check_writable(stereo_stats);
    const SatelliteStereoReport report = satellite_stereo_job(satellite, terminal_progress(quiet));
    write_stats(stereo_stats, to_json(report), {satellite.output});
  }
}

}  // namespace

Command stereo_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<Request>();
  StereoJobOptions& stereo = request->stereo;
  SatelliteStereoOptions& satellite = request->satellite;
  CLI::App* command = app.add_subcommand(
      "stereo",
      "DSM from images: satellite images with RPCs (IMG1 IMG2 ...) or frame cameras with known poses (--cameras): "
      "rectification, SGM, triangulation, median per cell");
  command->add_option("images", satellite.images,
                      "Satellite images with RPC cameras (TIFF tags, _RPC.TXT, .RPB or an OSSIM .geom beside "
                      "them), two or more: every overlapping pair is matched");
  command->add_option("--cameras", stereo.cameras,
                      "CAMERAS.json: CRS, cameras and images, optionally the height range (README)");
  command->add_option("--crs", satellite.crs,
                      "With satellite images: output CRS (default: WGS 84 / UTM of the scene; heights above the "
                      "WGS 84 ellipsoid)");
  command->add_flag("--allow-approximate-vertical", satellite.allow_approximate_vertical,
                    "With satellite images and a compound --crs whose geoid grid PROJ lacks: heights through "
                    "EGM96 (about 1 m off; --stats' transformation says so) instead of refusing");
  command->add_option("-o,--output", stereo.output, "Output GeoTIFF (Float32, nodata where nothing matched)")
      ->required();
  command->add_option("--res", stereo.resolution, "Cell size (CRS units: m)")->required();
  command->add_option("--pairs", stereo.pairs, "auto (overlap and base-to-height ratio) or pairs like 0-1,1-2")
      ->capture_default_str();
  command->add_option("--bounds", request->bounds, "x0,y0,x1,y1 of the DSM (CRS units); default: the pairs' overlap");
  command->add_option("--stats", request->stats, "Write counts and seconds per stage as JSON");
  command
      ->add_option("--fusion-memory", request->fusion_memory_mb,
                   "MB of memory for the points before the fusion spills sorted runs to $TMPDIR (or /tmp)")
      ->capture_default_str();
  command
      ->add_option("--band-memory", request->band_memory_mb,
                   "MB for one band of a frame pair's rectified images and matching (taller pairs go in bands of rows)")
      ->capture_default_str();
  command->add_flag("-q,--quiet", session.quiet, "No progress output");

  return {command, [request, &session] { run(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
