// Private to the picture writers: no-fly zones (ZoneLayer, picture.hpp) from above (render.cpp)
// and in the height profile (profile.cpp). zones.cpp.
#pragma once

#include <array>
#include <functional>
#include <vector>

#include "dsmplan/picture.hpp"
#include "picture/canvas.hpp"

namespace dsmplan::draw {

/// The zone's colour: kZoneBlocking when it blocks, else kZoneOther.
Rgb zone_colour(const AirspaceZone& zone, const AirspaceOptions& airspace);

/// True when (x, y) lies in the zone's area by the even-odd rule over all its rings.
bool area_contains(const AirspaceZone& zone, double x, double y);

/// The zones seen from above: `to_pixel` maps CRS x, y to continuous pixel coordinates; captions
/// at text scale `s`, recorded in `regions`.
void draw_zones_above(Canvas& canvas, const ZoneLayer& layer,
                      const std::function<std::array<double, 2>(double, double)>& to_pixel, int s,
                      std::vector<ImageRegion>& regions);

/// A stretch of the path (x,y distances from its start) whose x,y lies in a zone's area.
struct ZoneSpan {
  double from = 0, to = 0;
};
/// Where the path (`distance`: per point, from profile_path()) runs inside the zone's area, in
/// order, touching stretches merged. O(segments x corners).
std::vector<ZoneSpan> zone_spans(const AirspaceZone& zone, const std::vector<Point3>& path,
                                 const std::vector<double>& distance);

/// The zone's floor and ceiling (CRS heights) over a ground height `ground` (NaN: unknown);
/// -inf / +inf where there is none.
std::array<double, 2> zone_band(const AirspaceZone& zone, double ground);

/// A piece of a zone over the section: [from, to] along the path, its floor and ceiling (CRS
/// heights; -inf / +inf: none); `starts` on the first piece of each span.
struct ZonePiece {
  double from = 0, to = 0, floor = -INFINITY, ceiling = INFINITY;
  bool starts = false;
};
/// The spans cut at the ground's steps (`ground`: the DTM's steps, else the DSM's), each piece
/// with zone_band() over its step (a part no step covers: unknown ground).
std::vector<ZonePiece> zone_pieces(const AirspaceZone& zone, const std::vector<ZoneSpan>& spans,
                                   const std::vector<ProfileStep>& ground);

/// The pieces in the profile's plot canvas (`px`, `py`: distance and height to pixels): shaded
/// at alpha 0.2, outlined `width` pixels, the caption at the top of the widest span.
void draw_zone_section(Canvas& plot, const std::vector<ZonePiece>& pieces, const std::string& caption, Rgb colour,
                       const std::function<double(double)>& px, const std::function<double(double)>& py, double width,
                       int s);

}  // namespace dsmplan::draw
