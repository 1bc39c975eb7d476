// The pieces of `dsmplan plan` (plan_path.cpp) that `dsmplan serve` (serve_*.cpp) shares, so that
// both read the same files the same way and give the same bytes for the same flight.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/flight.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

/// What an output is: its format (--of, else the extension, as GDAL's newer command line
/// chooses), and the heights it states.
struct OutputKind {
  std::string ext;
  bool geojson = false;  ///< WGS 84, ellipsoidal heights
  bool msl = false;      ///< missions and KML: heights above mean sea level (EGM96)
  bool mission = false;  ///< missions take off from home and end (MissionJobOptions)
};

/// One output's format: `format` (--of), else its extension. ArgumentError("--of" or "-o").
OutputKind output_kind(const std::string& output, const std::string& format);

/// Every output of the run (-o, repeated) with its format, and the options that belong to them,
/// checked before anything is read. One of them a mission: the flight is planned as one, and the
/// others show it as flown, home legs included.
struct Outputs {
  std::vector<std::pair<std::string, OutputKind>> files;
  bool mission = false, geojson = false, msl = false, kml = false;
};

/// options.output and more_outputs with their kinds; ArgumentError for options that do not
/// belong to them ("--home", "--end", "--extrude", "--speed", "--hover-speed", "--of").
Outputs plan_outputs(const PlanJobOptions& options);

/// The transformations to WGS 84 the waypoints and the outputs need, made before planning, so
/// that an unknown or approximate vertical reference stops the run early. Each holds a PROJ
/// context of its own: one thread at a time.
struct Transforms {
  std::optional<Wgs84Transform> wgs84;   ///< GeoJSON in or out: ellipsoidal heights
  std::optional<Wgs84Transform> to_msl;  ///< missions and KML: heights above mean sea level
};

/// Makes those of `t` that GeoJSON waypoints (`geo_in`) and `outputs` need and `t` lacks (a
/// service keeps them from request to request); `description` says which were used.
void make_transforms(Transforms& t, const Crs& crs, bool geo_in, const Outputs& outputs,
                     const VerticalOptions& vertical, std::string& description);

/// The files of a mesh plan read into the stage's request, and what names a kept index.
struct ReadRequest {
  FlightRequest request;
  uint64_t index_key = 0;  ///< the index file's input hash: the mesh file's, and the DSM's (obstacle_key())
  double seconds = 0;      ///< spent reading
};

/// options.mesh, dsm, dtm and a kept index (--index) that fits the mesh file: without --dsm
/// nothing joins the mesh, so the file's hash names the index and only the mesh's header (its CRS)
/// is read; the vertices and triangles are in the index already. With --dsm the index is named by
/// the mesh file and the DSM together (their holes' columns join the mesh in it). An index built
/// later is written to options.index.
ReadRequest read_flight_request(const PlanJobOptions& options, std::vector<Point3> waypoints, const Progress& progress);

/// The kept roadmap of --roadmap: read when its file exists (and fits this mesh, ground and
/// options), else built and written there; nothing without --roadmap.
FlightStore file_store(const PlanJobOptions& options);

/// A flight and what its outputs carry with it: the waypoints (in `crs`) and the zones it was
/// planned around (a KML draws them).
struct FlightOutput {
  const FlightPlan& flight;
  const std::vector<Point3>& waypoints;
  const Crs& crs;
  const ZoneLayer& zones;
};

/// The bytes of one output of every format but .kmz (a ZIP written through GDAL: write_flight_as()),
/// in WGS 84 where the format asks (through `t`, made by make_transforms()). Missions fill
/// report.mission_items.
std::string flight_text(const PlanJobOptions& options, const OutputKind& kind, const FlightOutput& out,
                        const Transforms& t, PlanReport& report);

/// A flight's mission in WGS 84, heights above mean sea level (`lonlatamsl`: its path so);
/// fills report.mission_items.
Mission flight_mission(const FlightPlan& flight, const std::vector<Point3>& lonlatamsl, const Transforms& t,
                       PlanReport& report);

/// flight_text() written atomically to `output`, or the .kmz.
void write_flight_as(const PlanJobOptions& options, const std::string& output, const OutputKind& kind,
                     const FlightOutput& out, const Transforms& t, PlanReport& report);

// ---- --render, --profile (plan_pictures.cpp) ----

/// Before anything is read: each picture named .png and writable, and a DSM to draw it over
/// (--dsm, or a DSM input). ArgumentError("--render" / "--profile").
void check_flight_pictures(const PlanJobOptions& options, bool dsm_input);

/// What the pictures draw besides the flight, as the plan had it: the DSM and DTM in memory (null:
/// read from `dsm_file` and options.dtm), and the zones.
struct PictureData {
  std::string dsm_file;
  std::shared_ptr<const Grid> dsm, dtm;
  ZoneLayer zones;
};

/// The pictures options.render and options.profile ask for, drawn before any file of the run is
/// written (a refusal then leaves nothing behind): render_picture() and profile_picture() of the
/// flight as flown (flown_path()) with the waypoints, the zones, the plan's safety and ceiling,
/// the picture from above framed on the flight, titled "PATH over DSM" (PATH: the first CSV
/// output, else the first output), so each is the same bytes as `dsmplan render` (with the
/// report's window, zoom and title) and `dsmplan profile` give of the written CSV.
struct FlightPictures {
  std::optional<Image> render, profile;
  std::optional<RenderReport> render_report;  ///< the window and zoom drawn, to draw it again
  std::optional<ProfileReport> profile_report;
};
FlightPictures draw_flight_pictures(const PlanJobOptions& options, const FlightPlan& flight,
                                    const std::vector<Point3>& waypoints, const PictureData& data,
                                    const Progress& progress);
/// Writes them (write_png(), atomically).
void write_flight_pictures(const PlanJobOptions& options, const FlightPictures& pictures);

/// What a waypoint file's heights are: `option` (--waypoint-heights: crs or agl), else agl when
/// the CSV header of `file` names its height column "agl". ArgumentError("waypoint_heights") for
/// crs over such a header.
WaypointHeights waypoint_heights_of(const std::string& option, bool agl_column, const std::string& file);

/// GeoJSON waypoints [lon, lat, height] to the mesh's CRS: the height through `wgs84` when it is
/// ellipsoidal (WaypointHeights::crs), kept as it is when it is above the ground (agl).
void from_wgs84(std::vector<Point3>& waypoints, const Wgs84Transform& wgs84, WaypointHeights heights);

/// FlightReport::snapped as --stats and the GeoJSON's properties give it: a list of {waypoint,
/// from, to, distance_m, reason}, points in the mesh's CRS.
Json snapped_json(const std::vector<FlightReport::Snap>& snapped);

}  // namespace dsmplan
