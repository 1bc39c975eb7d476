// dsmplan/wpml.hpp: a mission as DJI's WPML `.kmz` (a zip written through GDAL, heights through
// PROJ's EGM96 grid), so it is in the GDAL layer (src/geo/wpml_writer.cpp); the other mission
// formats, which need neither, are in mission.hpp.
#pragma once

#include <string>

#include "dsmplan/mission.hpp"

namespace dsmplan {

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

}  // namespace dsmplan
