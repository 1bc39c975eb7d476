// dsmplan/export.hpp: stage 5, results out.
//
// Meshes are written with coordinates in the mesh's CRS, as doubles (binary PLY) or as
// shortest round-trip decimal text (OBJ, OFF), so nothing is lost to float32. Every file says
// its CRS and vertical reference in header comments:
//   PLY:  "comment crs_name ...", "comment crs_epsg N", "comment crs_wkt <single-line WKT2>",
//         "comment vertical ..." ("unknown" when the source did not say)
//   OBJ/OFF: the same lines behind '#'.
// GLB (binary glTF 2.0, for viewers and the web) is the exception: glTF positions are float32,
// so they are stored relative to an origin that the file records as doubles (see write_mesh).
// Writing is atomic: a temporary file in the target folder is renamed into place when complete;
// on any error nothing is left behind and OutputError names the file and the reason.
//
// read_mesh() reads those files back (and the usual variants other tools write) with the CRS;
// render_view() and write_png() draw a DSM and its mesh as a picture (the paper's Figures 6, 7).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

enum class MeshFormat { Ply, Obj, Off, Glb };

/// The format for a file name by its extension (.ply, .obj, .off, .glb, case-insensitive);
/// ArgumentError naming the extension otherwise.
MeshFormat mesh_format_for(const std::string& path);

/// The format named `name` ("ply", "obj", "off", "glb", case-insensitive), as GDAL's `--of`
/// names a driver; ArgumentError(option, ...) listing the names otherwise.
MeshFormat parse_mesh_format(const std::string& name, const std::string& option = "--of");
/// "ply", "obj", "off" or "glb".
const char* to_string(MeshFormat format);

/// Writes `mesh` to `path` in `format`, whatever the path's extension:
///   PLY  binary little-endian, double x,y,z and uint32 indices; O(vertices + triangles), streaming;
///   OBJ, OFF  text, shortest round-trip decimals; streaming;
///   GLB  binary glTF 2.0 (Khronos, https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html),
///        written with tinygltf, laid out as follows.
///        - Origin: the centre of the vertices' bounding box rounded to whole CRS units (as the
///          ClearanceIndex does), so vertex - origin is exact in double for coordinates on the
///          CRS's usual decimal grid.
///        - Positions: float32 POSITION accessor (min and max set) holding vertex - origin in
///          the CRS's axes (x east, y north, z up; CRS units). Each coordinate is off by at most
///          2^-24 of its local magnitude (a 1 km mesh: <= 30 micrometres).
///        - Indices: uint16 when there are at most 65535 vertices (65535 itself is the
///          primitive-restart value), else uint32; mode TRIANGLES; no normals, no material.
///        - Nodes: glTF is y-up, GIS meshes are z-up. The scene's root node "z-up to y-up" has
///          only a rotation, -90 degrees about x (quaternion [-sqrt(1/2), 0, 0, sqrt(1/2)]), so
///          viewers show the mesh upright (glTF x = east, y = up, z = south). Its one child,
///          "mesh", holds the mesh and translation = the origin as doubles, so child translation
///          + position = the vertex in the CRS, without the rotation.
///        - asset.generator "dsmplan VERSION"; asset.extras (JSON objects, fields that are not
///          known are left out): "crs" {"name", "epsg", "wkt"}, "vertical" {"name", "unit"},
///          "origin" [x, y, z] (CRS units, as the child's translation), "axes" (a sentence on
///          the above), "positions" ("float32, vertex minus origin").
///        - Triangles whose three corners are collinear or coincide once rounded to float32
///          (exact test) would have no area: they are left out, and the count is returned. This
///          is stricter than the Khronos validator, which flags only triangles naming a vertex
///          twice (ACCESSOR_INDEX_TRIANGLE_DEGENERATE). dsmplan's meshes of real data have none
///          (the tests check that); a mesh with no triangle left is written as the nodes alone,
///          without buffers. ArgumentError("mesh") when a triangle names a missing vertex.
///        The whole file is built in memory (about 3 x its size: 12 bytes a vertex, 6 or 12
///        bytes a triangle) before it is written; O(vertices + triangles).
/// Atomic; OutputError on failure. Returns the number of triangles left out (0 but for GLB).
size_t write_mesh(const Mesh& mesh, const std::string& path, MeshFormat format, const Progress& progress = {});

class AtomicFile;

/// A binary PLY written block by block as a MeshSink, for meshes larger than memory (the
/// streamed bounded mode): the same file write_mesh() writes for MeshFormat::Ply. Vertices go
/// straight to the file, face records to a scratch file beside it, appended by finish(); the
/// header's two counts are written last into fixed-width fields (the numbers, then spaces, as
/// PLY's whitespace-separated header allows). Memory: one block. Atomic: nothing appears at
/// `path` before finish(); destroyed without finish(), both temporary files are removed.
/// OutputError on any failure.
class PlyStreamWriter : public MeshSink {
public:
  PlyStreamWriter(const std::string& path, const Crs& crs);
  ~PlyStreamWriter() override;
  void append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) override;
  void finish();

private:
  std::string header(size_t vertices, size_t faces) const;
  std::unique_ptr<AtomicFile> file_, faces_;
  Crs crs_;
  size_t vertices_ = 0, faces_count_ = 0;
  std::vector<char> records_;
};

/// Writes `text` to `path` atomically (temporary file + rename). OutputError on failure.
void write_text_file(const std::string& path, const std::string& text);
/// write_text_file(), the last part of a result of several files (a mesh and its tileset.json,
/// outputs and their --stats): when it fails, the parts written before it (`written`; empty
/// names skipped) are removed too, then the error is rethrown. All or nothing.
void write_text_file_or_remove(const std::string& path, const std::string& text,
                               const std::vector<std::string>& written);

/// OutputError now when `path` could not be written (its temporary file is created next to it
/// and removed): for a second output written after the main one (--stats), so that a bad path
/// fails before the main output exists rather than after, leaving half of the outputs.
void check_writable(const std::string& path);

// ---- mesh files in ------------------------------------------------------------------------

/// Reads a triangle mesh written by write_mesh() or by another tool, in the mesh's own
/// coordinates. The format comes from the content (a PLY file starts with "ply", an OFF file
/// with "OFF"), else from the extension (.ply, .off), else it is read as OBJ:
///   PLY  ascii, binary_little_endian or binary_big_endian 1.0; vertex properties x, y, z as
///        float or double (others, lists too, are skipped); a face list "vertex_indices" (or
///        "vertex_index") with any integer count and index types (other face properties and
///        other elements are skipped);
///   OBJ  "v x y z [...]" and "f" with "v", "v/vt", "v/vt/vn" or "v//vn" words, 1-based or
///        negative (relative) indices; groups, materials, "vt", "vn", lines and points are ignored;
///   OFF  plain "OFF", a "vertices faces [edges]" line, "x y z" lines, "3 a b c [colour]" lines.
/// Vertices and triangles come in file order, indices unchanged, coordinates exactly as stored
/// (float properties widen to double exactly). GLB files are not read (InputError at "header":
/// glTF positions are float32, so use the PLY for further work). The CRS comes from the "crs_name", "crs_epsg",
/// "crs_wkt" and "vertical NAME (UNIT)" comments write_mesh() puts in the header ("unknown" gives
/// an empty field); `definition` is the WKT, else "EPSG:n"; `geographic` is read from the WKT's
/// first CRS keyword. A file without those comments gives an unknown CRS.
/// Throws InputError(path, place, problem), place "header", "line N" or "byte N", for: a missing
/// or unreadable file, anything that does not parse, a face that is not a triangle or names a
/// vertex twice, an index out of range, a coordinate that is NaN or infinite, more than 2^32-1
/// vertices, and a header that declares more records than the file can hold or fewer than it
/// holds (checked before anything is reserved). Memory O(file size + mesh), time O(file size).
Mesh read_mesh(const std::string& path, const Progress& progress = {});

// ---- pictures -----------------------------------------------------------------------------

/// Where a part of a picture lies, in pixels: [x0, x1) x [y0, y1).
struct ImageRegion {
  std::string what;  ///< "title", "north arrow", "scale bar", "legend", "label N"
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  ///< row-major from the top-left, 3 bytes (R, G, B) per pixel
  std::vector<ImageRegion> regions;  ///< render_view(): the furniture and the labels, as laid out
};

struct Window {
  double xmin = 0, ymin = 0, xmax = 0, ymax = 0;  ///< CRS units
};

/// Parses "xmin,ymin,xmax,ymax" (blanks allowed around the numbers); ArgumentError("--window")
/// when it is not four numbers. The order of the bounds is checked by render_view().
Window parse_window(const std::string& text);

/// Lines drawn over the picture: a path (one polyline), a roadmap (many two-point ones).
/// Coordinates in the DSM's CRS; z is not drawn.
struct LineLayer {
  std::vector<std::vector<Point3>> polylines;
  std::array<uint8_t, 3> colour{200, 0, 120};
  double width = 3;    ///< pixels
  float alpha = 1;     ///< 0..1
  bool halo = true;    ///< a white edge one pixel wider on each side, to stand out on any ground
};

/// Numbered discs, e.g. waypoints: 1, 2, 3 ... in order.
struct MarkerLayer {
  std::vector<Point3> points;
  std::array<uint8_t, 3> colour{255, 210, 0};
  double radius = 6;  ///< pixels
  bool numbered = true;
};

struct RenderOptions {
  std::vector<LineLayer> lines;      ///< drawn over the mesh edges, in order
  std::vector<MarkerLayer> markers;  ///< drawn last
  std::optional<Window> window;  ///< none: the whole grid
  double pixels_per_cell = 4;    ///< zoom: pixels per cell along x (y keeps the same scale)
  bool edges = true;             ///< draw the mesh's triangle edges
  bool scale_bar = true, north_arrow = true;
  bool legend = true;  ///< the height tint's ramp with its two ends in metres
  std::string title;  ///< drawn at the top-left (built-in 8x8 bitmap font, ASCII; others print as '?')
};

/// A picture of `dsm` seen from above, north up, with `mesh` (may be null) drawn over it.
/// The picture covers the window (default: the grid's outer cell edges) at pixels_per_cell /
/// cell_x pixels per CRS unit on both axes: width = round((xmax - xmin) * that), the same for
/// the height, at least 1. The ground is Horn's hillshade (sun from azimuth 315 degrees,
/// altitude 45 degrees, no vertical exaggeration) tinted lightly by height (green low, sand,
/// terracotta high, spread over the window's 2nd-98th height percentiles), interpolated
/// bilinearly between cell centres; nodata cells are pale blue, the area outside the grid is
/// light grey. Mesh edges are 1-pixel dark anti-aliased lines clipped to the picture, each edge
/// drawn once; they may move by up to half a pixel so that cell centres fall on pixel centres
/// (crisp lines at even zooms), and they are drawn lighter the shorter they are and the more of
/// the picture they would cover (a full-resolution mesh seen from afar). The scale bar
/// (bottom-left, a round 1/2/5 x 10^k length, labelled in metres; left out for geographic CRSs),
/// the height legend (the tint of flat ground from the 2nd to the 98th percentile, its ends in
/// metres), the north arrow (top-right) and the title (top-left, shortened with "..." when too
/// long) sit on light boxes that grow with the picture, are drawn over the map and the markers,
/// and are left out when they do not fit. The scale bar and the legend take the bottom corners,
/// scale bar left, unless the other way round covers fewer markers. Marker numbers are placed
/// at the first of eight places around their disc that meets no box, no other number and no
/// other disc (Image::regions records where each box and number went). The mesh must be in
/// the DSM's CRS. Throws ArgumentError for: a window that is empty, not finite or does not
/// overlap the grid ("--window"); pixels_per_cell not positive and finite ("--zoom"); a picture
/// over 30000 pixels a side or 2^26 pixels ("--zoom"); a triangle naming a missing vertex
/// ("mesh"), a line width or marker radius that is not in (0, 100] pixels ("layer"). Line layers
/// and markers (RenderOptions::lines, markers) are drawn over the mesh, clipped to the picture,
/// markers with their number (1-based) beside them. Time O(pixels + triangles + e log e +
/// layer segments), e = edges over the picture.
Image render_view(const Grid& dsm, const Mesh* mesh, const RenderOptions& options);

/// The panels left to right, top-aligned, `gap` white pixels apart, shorter ones padded white.
/// ArgumentError when there is no panel, a panel's pixel array does not match its size, or
/// gap < 0.
Image side_by_side(const std::vector<Image>& panels, int gap = 8);

// ---- the height profile of a path (src/export/profile.cpp) --------------------------------

/// A stretch along the path under which one raster cell lies: distances from the path's start
/// (x,y length, CRS units) and that cell's height (NaN: nodata, or outside the raster).
struct ProfileStep {
  double from = 0, to = 0;
  float z = NAN;
};

/// What lies under a path, exactly: the path's x,y projection is cut at every cell boundary of
/// the raster it crosses, so each step is one cell (neighbouring pieces over the same height
/// merged). Heights above a cell are taken at both ends of each piece: the path is straight
/// between its points, so they are the least and greatest over the piece, exactly.
struct PathProfile {
  double length = 0;              ///< x,y length of the path
  std::vector<double> distance;   ///< per path point, its distance from the start
  std::vector<ProfileStep> dsm;   ///< the DSM cells under the path, in order
  std::vector<ProfileStep> dtm;   ///< the DTM's, when there is one (its own cells)
  /// Least path height above the DSM cell below (negative: inside it), and where; NaN when no
  /// valid DSM cell is under the path.
  double min_above_dsm = NAN, min_above_dsm_at = NAN;
  /// Greatest path height above the ground (the DTM where it has data, else, without a DTM, the
  /// DSM cell below), and where; NaN when there is no ground under the path.
  double max_above_ground = NAN, max_above_ground_at = NAN;
};

/// The profile of `path` (x, y, z in the rasters' CRS) over `dsm` and `dtm` (may be null; its
/// own cell size and extent). ArgumentError("path") for fewer than two points or a point that is
/// not finite. O(points + cells crossed).
PathProfile profile_path(const std::vector<Point3>& path, const Grid& dsm, const Grid* dtm);

struct ProfileOptions {
  int width = 1200, height = 500;  ///< pixels
  std::string title;               ///< above the plot (ASCII; empty: none)
  double safety = 2;               ///< the band around the path: +-safety (0: no band)
  double max_agl = 120;            ///< the ceiling: ground + max_agl
  std::vector<Point3> waypoints;   ///< numbered markers on the path (may be empty)
  /// The height axis, bottom and top (CRS height units); NaN: fitted to everything drawn.
  double z_min = NAN, z_max = NAN;
};

/// A picture of the path's height profile: distance along the path (x axis, 0 to the path's
/// length, exactly the plot's width) against height (y axis), with
///   - the DSM under the path (profile_path().dsm) as a filled grey silhouette (buildings as steps),
///   - the DTM (when given) as a brown step line, gaps where it has no data,
///   - the ceiling, ground + max_agl (ground: the DTM, else the DSM below), a red dashed line,
///   - the safety band, path height +-safety, translucent magenta, and the path, thick magenta
///     (#ff00ff),
///   - each waypoint as a numbered yellow disc on the path where the path passes nearest it (3D),
///   - a light grid, axes with tick labels in metres, axis titles, the title, and a legend
///     below the plot naming each element present.
/// The plot area is framed by a 1-pixel dark box just outside it; inside, distance d and height
/// z sit at x = left + d / length * plot width, y = bottom - (z - z_min) / (z_max - z_min) *
/// plot height (pixel edges). Everything but the waypoints is clipped to the plot area. The
/// fitted height axis spans every drawn height with a margin, rounded out to whole ticks.
/// Throws ArgumentError for: a size under 240 x 160 or over 30000 a side or 2^26 pixels
/// ("--width"/"--height"); safety < 0 or not finite ("--safety"); max_agl not positive and
/// finite ("--max-agl"); z_min >= z_max or only one given ("height axis"); a path as
/// profile_path() refuses, or with no x,y length ("path"). O(pixels + points + cells crossed).
Image render_profile(const std::vector<Point3>& path, const Grid& dsm, const Grid* dtm, const ProfileOptions& options);

/// Writes an 8-bit RGB PNG (libpng, default compression). Atomic like the mesh writers;
/// OutputError on failure, ArgumentError when the image is empty or its array has the wrong size.
void write_png(const Image& image, const std::string& path);

// ---- WGS 84: longitude, latitude, height (PROJ; in the library dsmplan_gdal) --------------
//
// Coordinates leave dsmplan in WGS 84 for GeoJSON (RFC 7946: longitude, latitude, height above
// the ellipsoid) and drone missions (height above mean sea level, EGM96). The horizontal part
// is exact; the vertical part needs the data's vertical reference (from a compound CRS, or
// VerticalOptions::vertical_crs) and a geoid grid PROJ has. Where PROJ has only a "ballpark"
// operation (heights copied across datums: for Germany's DHHN2016 without the GCG2016 grid,
// about 47 m wrong), or the reference is unknown, construction fails unless
// allow_approximate_vertical; then the heights are taken as EGM96 heights (EPSG:5773) and go
// through PROJ's EGM96 grid: off by the difference between their datum and EGM96 (typically under
// 1 m), never by the geoid's height. description() names the operation used, and the tools print it.

enum class HeightReference {
  Ellipsoid,    ///< WGS 84 ellipsoidal height (EPSG:4979), GeoJSON's
  MeanSeaLevel  ///< EGM96 height (EPSG:5773), what ground stations call AMSL
};

struct VerticalOptions {
  std::string vertical_crs;  ///< the heights' vertical CRS when the data does not say (e.g. "EPSG:7837")
  bool allow_approximate_vertical = false;  ///< take heights of an unknown or grid-less datum as EGM96 heights
};

class Wgs84Transform {
public:
  /// From `crs` (+ the vertical reference) to WGS 84 longitude, latitude (degrees) and the
  /// height `target`. `area` (west, south, east, north in degrees, NaN = anywhere) picks the
  /// operation valid there. Throws ArgumentError("--vertical-crs") when the vertical reference
  /// is unknown or only approximately transformable and that is not allowed;
  /// ArgumentError("crs") when PROJ cannot read the CRS or has no transformation.
  Wgs84Transform(const Crs& crs, HeightReference target, const VerticalOptions& options = {},
                 const std::array<double, 4>& area = {NAN, NAN, NAN, NAN});
  ~Wgs84Transform();
  Wgs84Transform(Wgs84Transform&&) noexcept;

  /// x, y, z in the CRS to longitude, latitude, height. ArgumentError("crs") when PROJ fails.
  Point3 to_wgs84(const Point3& p) const { return apply(p, true); }
  /// The inverse: longitude, latitude, height to x, y, z in the CRS.
  Point3 from_wgs84(const Point3& p) const { return apply(p, false); }
  /// PROJ's name of the operation, e.g. "UTM zone 32N to ETRS89 + ...", then "; heights from
  /// <the data's vertical CRS> to <EGM96 height (mean sea level) | WGS 84 ellipsoidal height>"
  /// (PROJ's name omits a vertical step that is the identity); says when heights are approximate
  /// or copied.
  const std::string& description() const { return description_; }
  bool approximate_heights() const { return approximate_; }

private:
  Point3 apply(const Point3& p, bool forward) const;
  struct State;
  std::unique_ptr<State> state_;
  std::string description_;
  bool approximate_ = false;
};

// ---- 3D Tiles: a GLB placed on the globe (in the library dsmplan_gdal) ---------------------
//
// A 3D Tiles 1.1 tileset (OGC 22-025r4, "3D Tiles Specification 1.1") of one tile whose content
// is a GLB of write_mesh(): what CesiumJS and other globe viewers open. The GLB keeps its
// coordinates (the mesh's CRS, z up; the viewer undoes its root node's y-up turn, as the
// specification's "glTF up-axis" section says); the tile's `transform` maps those coordinates
// to Earth-centred, Earth-fixed ones (EPSG:4978, metres). A projected CRS is not a local
// east-north-up frame (grid convergence, scale factor, the Earth's curvature), so the transform
// is the affine map that fits PROJ's exact transform best (least squares) over the mesh's
// bounding box, and its largest departure from PROJ's, measured on a lattice through the box,
// is reported and bounded.

/// The largest departure from PROJ's transform a tileset may have: the mesh's own default
/// height step (--zstep 0.1 m). Reached by a mesh about 2.2 km across (the sagitta, (d/2)^2 / 2R).
constexpr double kTilesetMaxPlacementError = 0.1;

struct TilesetPlacement {
  std::array<double, 16> transform{};  ///< column-major 4x4: CRS x, y, z (metres) to ECEF
  std::array<double, 12> box{};        ///< boundingVolume.box in CRS coordinates: centre, 3 half-axes
  double max_error_m = 0;              ///< largest |affine - PROJ| over a 9 x 9 x 3 lattice of the box
  std::string heights;                 ///< the operation used (Wgs84Transform::description())
};

/// Fits the tile transform for `mesh` (its bounding box) through `to_ellipsoid` (a Wgs84Transform
/// to HeightReference::Ellipsoid; WGS 84 geodetic to ECEF in closed form). Throws
/// ArgumentError("--3dtiles") for a mesh without vertices, or when max_error_m would exceed
/// kTilesetMaxPlacementError (the message gives the mesh's size and asks for smaller tiles);
/// ArgumentError("crs") when PROJ cannot transform a corner. O(vertices) + 319 transforms.
TilesetPlacement place_on_globe(const Mesh& mesh, const Wgs84Transform& to_ellipsoid);

/// tileset.json text: asset.version "1.1", one root tile (refine ADD, geometricError 0) with the
/// placement's transform and box and `content.uri` (the GLB's name relative to the tileset),
/// tileset geometricError the box's diagonal; asset.extras names the CRS, the height operation
/// and max_error_m.
std::string tileset_json(const TilesetPlacement& placement, const std::string& content_uri, const Crs& crs);

// ---- paths as files -----------------------------------------------------------------------

/// The CSV of a path: "x,y,z" then one point a line, shortest decimals that read back exactly.
std::string path_to_csv(const std::vector<Point3>& path);

/// A GeoJSON (RFC 7946) Feature with a LineString of [longitude, latitude, height] positions
/// (degrees to 1e-9, about 0.1 mm; heights to 1 mm), and `properties` (a JSON object's text,
/// "{}" for none). Plain text, no PROJ: the caller transforms (Wgs84Transform).
std::string path_to_geojson(const std::vector<Point3>& lonlath, const std::string& properties = "{}");

// ---- drone missions and KML (formatting only; the caller transforms) ----------------------
//
// Input: WGS 84 longitude, latitude (degrees) and height above mean sea level (EGM96,
// Wgs84Transform with HeightReference::MeanSeaLevel): what MAVLink's MAV_FRAME_GLOBAL and
// QGroundControl call AMSL, and what KML 2.2 states its altitudes in (CRS LonLat84_5773).
// Degrees are written to 1e-9 (0.1 mm), altitudes to 1 mm. ArgumentError when a point is not
// finite or outside longitude [-180, 180], latitude [-90, 90] (e.g. still in UTM).
// The formats' sources (QGC's and MAVLink's documentation, the autopilots' mission checks,
// OGC KML 2.2): mission_writers.cpp.

enum class Firmware { generic, px4, ardupilot };  ///< MAV_AUTOPILOT 0, 12, 3
enum class MissionEnd { rtl, land, none };        ///< after the route: return to launch, land there, nothing
enum class AltitudeFrame {
  relative,  ///< metres above home (MAV_FRAME_GLOBAL_RELATIVE_ALT, QGC AltitudeMode 1): how most missions fly
  amsl       ///< metres above mean sea level (MAV_FRAME_GLOBAL, QGC AltitudeMode 2)
};

/// A mission as an autopilot flies it: armed at `home` on the ground, a vertical takeoff to
/// route[0] (directly above home), straight lines through the route, then `end`.
struct Mission {
  Point3 home{NAN, NAN, NAN};  ///< lon, lat, AMSL height of the ground at home (the planned home)
  std::vector<Point3> route;   ///< lon, lat, AMSL; route[0] is the top of the takeoff, above home
  MissionEnd end = MissionEnd::rtl;
  Point3 land{NAN, NAN, NAN};  ///< end == land: lon, lat, AMSL height of the ground it lands on
};

/// Takeoff tops closer to home than this are refused: PX4 accepts a takeoff only 1 m above its
/// altitude acceptance radius (0.8 m by default), and lower than that is no flight anyway.
constexpr double kMinTakeoffHeight = 2.0;

struct MissionOptions {
  Firmware firmware = Firmware::generic;  ///< .plan's firmwareType; NAV_* items are common to all three
  AltitudeFrame altitude_frame = AltitudeFrame::relative;
  /// m/s along the route: a MAV_CMD_DO_CHANGE_SPEED (ground speed) after the takeoff, and the
  /// .plan's cruiseSpeed. (0, 100].
  double speed = 5;
  double hover_speed = 5;  ///< m/s, .plan's hoverSpeed (QGC's time estimate for multirotors). (0, 100]
  int vehicle_type = 2;    ///< .plan: MAV_TYPE, 2 = quadrotor
  std::string name = "dsmplan path";  ///< KML: the Document's name
  std::string description;            ///< KML: the Document's description (e.g. the transformation), may be empty
  bool extrude = false;               ///< KML: <extrude>1</extrude>, a wall from the path down to the ground
};

/// The mission items, in this order for both formats: MAV_CMD_NAV_TAKEOFF (22) at home to the
/// altitude of route[0]; MAV_CMD_DO_CHANGE_SPEED (178: ground speed, `speed`, throttle -1);
/// MAV_CMD_NAV_WAYPOINT (16) for route[1..]; then MAV_CMD_NAV_RETURN_TO_LAUNCH (20) or
/// MAV_CMD_NAV_LAND (21) at `land`, or nothing. Altitudes in `altitude_frame`; relative ones
/// are the AMSL height less home's. What the autopilots check is met: ArduPilot's first
/// navigation command after home (item 0 of a WPL) is the takeoff (AP_Mission::
/// starts_with_takeoff_cmd, else "Missing Takeoff Cmd"); PX4's takeoff is the first item with a
/// position and above home (FeasibilityChecker::checkTakeoff).
/// ArgumentError: an empty route; a point as above; route[0] more than 1e-7 degrees from above
/// home; a takeoff less than kMinTakeoffHeight above home; end == land without a land point;
/// speeds outside (0, 100].
///
/// A QGroundControl plan (JSON, "Plan File Format"): fileType "Plan", version 1; mission version
/// 2 with firmwareType, vehicleType, cruiseSpeed, hoverSpeed, globalPlanAltitudeMode (1 relative,
/// 2 absolute), plannedHomePosition [lat, lon, AMSL] of home; SimpleItems {autoContinue true,
/// command, doJumpId 1.., frame, params [p1..p4, lat, lon, alt], type}; positional items also
/// AMSLAltAboveTerrain null, Altitude, AltitudeMode. Empty geoFence and rallyPoints (version 2).
std::string mission_to_qgc_plan(const Mission& mission, const MissionOptions& options = {});

/// A MAVLink plain-text mission, "QGC WPL 110" (Mission Planner's .waypoints, ArduPilot's): the
/// header line, then "INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 LATITUDE LONGITUDE ALTITUDE
/// AUTOCONTINUE" separated by tabs: line 0 is home (current 1, frame 0, AMSL, as ArduPilot
/// keeps it), then the items as mission_to_qgc_plan() lists them (current 0, autocontinue 1).
/// Latitude comes before longitude. Errors as mission_to_qgc_plan().
std::string mission_to_qgc_wpl(const Mission& mission, const MissionOptions& options = {});

/// A DJI WPML mission (.kmz, DJI Cloud API "DJI WPML", namespace wpmz/1.0.2): a ZIP holding
/// wpmz/template.kml and wpmz/waylines.wpml, the same route as mission_to_qgc_plan(): one
/// Placemark per route point from the takeoff top on, flown in straight lines that stop at each
/// point (toPointAndStopWithDiscontinuityCurvature); takeOffSecurityHeight the takeoff's height;
/// finishAction goHome (rtl), autoLand (land) or noAction. Heights: relative to the start point,
/// or for amsl executed as WGS 84 ellipsoidal heights through PROJ's EGM96 grid (WPML has no
/// EGM96 execution mode; the template states EGM96). Written atomically to `path` (GDAL's zip).
/// Errors as mission_to_qgc_plan(), and ArgumentError for a landing not under the last point or
/// more than 65,536 points; OutputError when it cannot write.
void write_wpml_kmz(const Mission& mission, const MissionOptions& options, const std::string& path);

/// KML 2.2: a Document with a Placemark "path" whose LineString has <altitudeMode>absolute
/// </altitudeMode> and "lon,lat,alt" tuples one a line, then a Point Placemark "waypoint k"
/// (also absolute) for each of `marks` (may be empty). Without altitudeMode a viewer would clamp
/// the path to the ground. Styles: the path a magenta line 4 px wide (its extrusion translucent),
/// the waypoints cyan; `extrude` adds a wall down to the ground under each. Name and
/// description are XML-escaped.
std::string path_to_kml(const std::vector<Point3>& lonlatamsl, const std::vector<Point3>& marks = {},
                        const MissionOptions& options = {});

/// The path without the points that lie within `tolerance` of the straight segment between the
/// points kept around them (first and last always kept), so that every mission item is a turn:
/// the result is within `tolerance` of the path and the path within `tolerance` of it
/// (Hausdorff). For points in a metric CRS. O(n * longest dropped run).
std::vector<Point3> drop_straight_points(const std::vector<Point3>& path, double tolerance);

}  // namespace dsmplan
