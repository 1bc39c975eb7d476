// dsmplan/picture.hpp: stage 5, results out: pictures a person can read.
//
// render_view() draws a DSM seen from above with its mesh, a path, a roadmap and waypoints (the
// paper's Figures 6 and 7); render_profile() a path seen from the side over the DSM and the
// terrain; write_png() writes either; both draw no-fly zones (ZoneLayer). src/picture/render.cpp,
// profile.cpp, zones.cpp, png_writer.cpp.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/airspace.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

/// Where a part of a picture lies, in pixels: [x0, x1) x [y0, y1).
struct ImageRegion {
  /// "title", "north arrow", "scale bar", "legend", "label N", "x VALUE" / "y VALUE" (a grid
  /// line's label, VALUE as printed: the box's centre lies on the line)
  std::string what;
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;          ///< row-major from the top-left, 3 bytes (R, G, B) per pixel
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
  double width = 3;  ///< pixels
  float alpha = 1;   ///< 0..1
  bool halo = true;  ///< a white edge one pixel wider on each side, to stand out on any ground
};

/// Numbered discs, e.g. waypoints: 1, 2, 3 ... in order.
struct MarkerLayer {
  std::vector<Point3> points;
  std::array<uint8_t, 3> colour{255, 210, 0};
  double radius = 6;  ///< pixels
  bool numbered = true;
};

/// No-fly zones to draw (airspace.hpp's AirspaceZone, x, y in the DSM's CRS, as read_airspace()
/// gives them). A zone that blocks (zone_blocks(zone, airspace)) is drawn in kZoneBlocking, the
/// others in kZoneOther; each is named by zone_caption(). Empty: nothing drawn, and the picture is
/// the same to the byte as without the layer.
struct ZoneLayer {
  std::vector<AirspaceZone> zones;
  AirspaceOptions airspace;  ///< which restrictions block
};
inline constexpr std::array<uint8_t, 3> kZoneBlocking{204, 0, 0};  ///< dark red
inline constexpr std::array<uint8_t, 3> kZoneOther{230, 140, 0};   ///< amber
/// A zone's name in pictures: its name, else its identifier, else "zone N" (N = index + 1).
std::string zone_caption(const AirspaceZone& zone, size_t index);

struct RenderOptions {
  /// Drawn over the mesh edges and under the lines: each zone's area (even-odd: holes left out)
  /// tinted in its colour at alpha 0.15, every ring's outline 2 pixels wide and opaque, and its
  /// caption in its colour on a light box centred on the visible part of its outer ring's box
  /// (Image::regions: "zone CAPTION"). A zone wholly outside the picture is not drawn.
  ZoneLayer zones;
  std::vector<LineLayer> lines;      ///< drawn over the mesh edges, in order
  std::vector<MarkerLayer> markers;  ///< drawn last
  std::optional<Window> window;      ///< none: the whole grid
  double pixels_per_cell = 4;        ///< zoom: pixels per cell along x (y keeps the same scale)
  bool edges = true;                 ///< draw the mesh's triangle edges
  bool scale_bar = true, north_arrow = true;
  bool legend = true;  ///< the height tint's ramp from the lowest to the highest cell, in metres
  bool grid = true;    ///< faint grid lines in the CRS, labelled along the top and left edges
  std::string title;   ///< drawn at the top-left (built-in 8x8 bitmap font, ASCII; others print as '?')
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
/// the height legend (the tint of flat ground as the map colours each height, from the lowest
/// cell under the picture to the highest, its ends in metres rounded outwards), the coordinate
/// grid (faint lines every round 1/2/5 x 10^k CRS units, about five across, each labelled with
/// its coordinate on a light box centred on the line along the top edge for x, the left edge for
/// y, where it meets no other box), the north arrow (top-right) and the title (top-left, shortened with "..." when too
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

// ---- the height profile of a path (src/picture/profile.cpp) --------------------------------

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
  double length = 0;             ///< x,y length of the path
  std::vector<double> distance;  ///< per path point, its distance from the start
  std::vector<ProfileStep> dsm;  ///< the DSM cells under the path, in order
  std::vector<ProfileStep> dtm;  ///< the DTM's, when there is one (its own cells)
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
  /// No-fly zones: where the path's x,y runs inside a zone's area (exactly: each segment cut where
  /// it crosses a ring), the zone's volume over that part of the section, from its floor to its
  /// ceiling: an AGL limit over the ground below (the DTM where it has data, else the DSM, step
  /// by step as the ceiling's ground; no ground: no floor, no top, as airspace.hpp counts it), a
  /// CRS height as it is, an unlimited one to the plot's edge. Shaded in the zone's colour at
  /// alpha 0.2 under the safety band, outlined 1.5 pixels, captioned at its top inside the plot;
  /// the legend names the zones that block and the others. A fitted height axis takes in each
  /// zone's finite floors and ceilings along the path that lie at most max_agl above the
  /// highest ceiling of the path (higher ones are cut by the plot's top).
  ZoneLayer zones;
  /// The free airspace's floor along the path: (distance along the path, the lowest height that
  /// keeps `safety` from the DSM's columns there; NaN: a gap), drawn as a dark blue dotted line
  /// where the path may not go below (empty: not drawn). profile_job() fills it.
  std::vector<std::array<double, 2>> lowest_clear;
};

/// A picture of the path's height profile: distance along the path (x axis, 0 to the path's
/// length, exactly the plot's width) against height (y axis), with
///   - the DSM under the path (profile_path().dsm) as a filled grey silhouette (buildings as steps),
///   - the DTM (when given) as a brown step line, gaps where it has no data,
///   - the ceiling, ground + max_agl (ground: the DTM, else the DSM below), a red dashed line,
///   - the lowest clear height (options.lowest_clear), a dark blue dotted line,
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

}  // namespace dsmplan
