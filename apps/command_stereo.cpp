// dsmplan stereo: stereo_job() for frame cameras (--cameras), satellite_stereo_job() for images
// with RPCs; the flags' rules are the library's (stereo_job_for()).
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/satellite_stereo_job.hpp"
#include "dsmplan/stereo_job.hpp"

namespace dsmplan::cli {

namespace {

struct StereoArguments {
  StereoRequest stereo;
  std::string stats;
};

void run_stereo(const StereoArguments& request, bool quiet) {
  const StereoJob job = stereo_job_for(request.stereo);  // the flags' rules, as every caller gets them
  const std::string& output = request.stereo.output;
  if (job.frame) {
    refuse_overwrites(stereo_job_inputs(*job.frame), {{"-o", output}, {"--stats", request.stats}});
    if (!request.stats.empty()) check_writable(request.stats);
    const StereoReport report = stereo_job(*job.frame, terminal_progress(quiet));
    // The progress (stdout) ended and flushed before the lines below (stderr): they broke it
    // ("...90dsmplan: COLMAP model ...").
    end_progress_line();
    for (const std::string& warning : report.warnings) std::fprintf(stderr, "dsmplan: warning: %s\n", warning.c_str());
    if (report.georeference && !quiet) {
      const Georeference& g = *report.georeference;
      std::fprintf(stderr, "dsmplan: COLMAP model in %s by the %s (scale %.6g)", request.stereo.crs.c_str(),
                   g.method == "centres" ? "similarity fitted to the centres"
                   : g.method == "exif"  ? "similarity fitted to the images' EXIF GPS centres"
                   : g.method == "gcps"  ? "similarity fitted to the ground control points"
                                         : "transform given",
                   g.scale);
      if (g.centres)
        std::fprintf(stderr, ": residuals at %zu centres RMS %.3f m, max %.3f m (%s), bound %.2f m", g.centres, g.rms,
                     g.max, g.worst.c_str(), g.bound);
      if (g.gcps)
        std::fprintf(stderr,
                     ": residuals at %zu ground control points RMS %.3f m, max %.3f m (point %s), bound %.2f m; "
                     "reprojection at most %.2f px",
                     g.gcps, g.rms, g.max, g.worst.c_str(), g.bound, g.gcp_reprojection_max);
      std::fprintf(stderr, "\n");
      if (!g.heights.empty()) std::fprintf(stderr, "dsmplan: heights: %s\n", g.heights.c_str());
    }
    write_stats(request.stats, to_json(report), {output});
  } else {
    refuse_overwrites(satellite_stereo_inputs(*job.satellite), {{"-o", output}, {"--stats", request.stats}});
    if (!request.stats.empty()) check_writable(request.stats);
    const SatelliteStereoReport report = satellite_stereo_job(*job.satellite, terminal_progress(quiet));
    write_stats(request.stats, to_json(report), {output});
  }
}

}  // namespace

Command stereo_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<StereoArguments>();
  StereoRequest& stereo = request->stereo;
  CLI::App* command = app.add_subcommand(
      "stereo",
      "DSM from images: satellite images with RPCs (IMG1 IMG2 ...), frame cameras with known poses (--cameras) or "
      "a COLMAP model (--colmap): "
      "rectification, SGM, triangulation, median per cell");
  command->add_option("images", stereo.images,
                      "Satellite images with RPC cameras (TIFF tags, _RPC.TXT, .RPB or an OSSIM .geom beside "
                      "them), two or more: every overlapping pair is matched");
  command->add_option("--cameras", stereo.cameras,
                      "CAMERAS.json: CRS, cameras and images, optionally the height range (docs/stereo.md)");
  command->add_option("--colmap", stereo.colmap,
                      "COLMAP text model folder (cameras.txt, images.txt) instead of --cameras; needs --crs and "
                      "--centres, --gcps or --transform (docs/stereo.md)");
  command->add_option("--centres", stereo.centres,
                      "With --colmap: CSV of image,x,y,z, the cameras' centres in --crs, or 'exif': the images' "
                      "EXIF GPS (altitude taken as EGM96 height, converted by PROJ); a similarity is fitted "
                      "(Umeyama) and refused when its RMS residual exceeds max(0.5 m, 1 % of the centres' extent)");
  command->add_option("--gcps", stereo.gcps,
                      "With --colmap, instead of --centres: CSV of ground control points, header x,y,z,image,u,v "
                      "(and optionally point), one row per point and image; each point seen in 2 or more images is "
                      "triangulated and the similarity fitted to them, by the same bound");
  command->add_option("--transform", stereo.transform,
                      "With --colmap: the model -> --crs similarity: a 4x4 matrix by rows, its first 3 rows, or "
                      "scale, rotation by rows, translation");
  command->add_option("--images", stereo.colmap_images,
                      "With --colmap: the images' folder (default: image_path in the model's project.ini, else "
                      "images/ beside the model's folder, else the model's folder)");
  command->add_option("--crs", stereo.crs,
                      "With satellite images: output CRS (default: WGS 84 / UTM of the scene; heights above the "
                      "WGS 84 ellipsoid). With --colmap: the CRS of the centres or transform and of the DSM");
  command->add_flag("--allow-approximate-vertical", stereo.allow_approximate_vertical,
                    "With satellite images and a compound --crs whose geoid grid PROJ lacks: heights through "
                    "EGM96 (about 1 m off; --stats' transformation says so) instead of refusing");
  command->add_option("-o,--output", stereo.output, "Output GeoTIFF (Float32, nodata where nothing matched)")
      ->required();
  command->add_option("--res", stereo.resolution, "Cell size (CRS units: m)")->required();
  command->add_option("--pairs", stereo.pairs, "auto (overlap and base-to-height ratio) or pairs like 0-1,1-2")
      ->capture_default_str();
  command->add_option("--bounds", stereo.bounds, "x0,y0,x1,y1 of the DSM (CRS units); default: the pairs' overlap");
  command->add_option("--stats", request->stats, "Write counts and seconds per stage as JSON");
  command
      ->add_option("--fusion-memory", stereo.fusion_memory_mb,
                   "MB of memory for the points before the fusion spills sorted runs to $TMPDIR (or /tmp)")
      ->capture_default_str();
  command
      ->add_option("--band-memory", stereo.band_memory_mb,
                   "MB for one band of a frame pair's rectified images and matching (taller pairs go in bands of rows)")
      ->capture_default_str();
  command->add_flag("-q,--quiet", session.quiet, "No progress output");

  return {command, [request, &session] { run_stereo(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
