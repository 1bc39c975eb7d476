// Whether a CRS measures in ground metres, by PROJ alone (metric_crs.cpp): what metric_problem()
// (gdal_io.cpp) checks first, and what the dsmplan binary's stub of it checks before it loads
// GDAL (gdal_stubs.cpp), so that planning over a mesh in a metric CRS never loads GDAL.
// Internal to src/geo.
#pragma once

#include <string>

#include "dsmplan/core.hpp"

namespace dsmplan {

/// True when x, y and heights are metres on the ground where dsmplan measures: for a 1 m error
/// of a length, the unit must be exactly the metre and the scale within 1 + 1e-9.
bool is_metre(double metres);

/// How far lengths in the projected CRS `text` depart from lengths on the ground at (x, y): the
/// larger of |h - 1| and |k - 1|, the meridional and parallel scale factors. 0 where there is no
/// projection to measure (a local engineering CRS) or PROJ cannot invert it there.
double scale_departure(const std::string& text, double x, double y);

/// True when PROJ alone shows that metric_problem(crs, ..., x, y, units_only) accepts `crs`: a
/// projected CRS (a compound one's horizontal part) whose axes are in metres, heights in
/// metres or not stated, and (unless `units_only`) lengths within kMaxScaleDeparture of the
/// ground's at (x, y). False proves nothing: metric_problem() then decides, and says why.
bool proven_metric(const Crs& crs, double x, double y, bool units_only);

}  // namespace dsmplan
