// A CRS's units and scale by PROJ's C API alone (metric_crs.hpp), without GDAL.
#include "metric_crs.hpp"

#include <proj.h>

#include <cmath>
#include <vector>

#include "dsmplan/raster_io.hpp"

namespace dsmplan {

namespace {

// PJ objects made from one context, destroyed with it, in reverse.
class ProjScope {
public:
  ProjScope() : ctx_(proj_context_create()) { proj_log_level(ctx_, PJ_LOG_NONE); }
  ~ProjScope() {
    for (auto it = made_.rbegin(); it != made_.rend(); ++it) proj_destroy(*it);
    proj_context_destroy(ctx_);
  }
  ProjScope(const ProjScope&) = delete;
  ProjScope& operator=(const ProjScope&) = delete;
  PJ_CONTEXT* ctx() const { return ctx_; }
  PJ* keep(PJ* p) {
    if (p) made_.push_back(p);
    return p;
  }

private:
  PJ_CONTEXT* ctx_;
  std::vector<PJ*> made_;
};

// A bound CRS (WKT1's TOWGS84) is its source CRS with a datum shift: the units are the source's.
PJ* unbound(ProjScope& scope, PJ* crs) {
  while (crs && proj_get_type(crs) == PJ_TYPE_BOUND_CRS) crs = scope.keep(proj_get_source_crs(scope.ctx(), crs));
  return crs;
}

// Every axis of the CRS's coordinate system in metres (and at least one axis).
bool axes_in_metres(ProjScope& scope, PJ* crs) {
  PJ* cs = crs ? scope.keep(proj_crs_get_coordinate_system(scope.ctx(), crs)) : nullptr;
  const int axes = cs ? proj_cs_get_axis_count(scope.ctx(), cs) : 0;
  if (axes <= 0) return false;
  for (int i = 0; i < axes; ++i) {
    double factor = 0;
    if (!proj_cs_get_axis_info(scope.ctx(), cs, i, nullptr, nullptr, nullptr, &factor, nullptr, nullptr, nullptr) ||
        !is_metre(factor))
      return false;
  }
  return true;
}

}  // namespace

bool is_metre(double metres) { return std::abs(metres - 1) < 1e-9; }

// The scale factors as finite differences of the CRS's own conversion (its projection,
// geographic degrees to x, y) over 1e-5 degrees, against the arcs of its ellipsoid (meridian
// M dphi, parallel N cos(phi) dlambda). PROJ's proj_factors() computes the same but would build
// an operation from the CRS each time (10-20 ms); the conversion alone costs well under a
// millisecond.
double scale_departure(const std::string& text, double x, double y) {
  ProjScope scope;
  PJ_CONTEXT* ctx = scope.ctx();
  double departure = 0;
  PJ* crs = scope.keep(proj_create(ctx, text.c_str()));
  if (crs && proj_get_type(crs) == PJ_TYPE_COMPOUND_CRS) crs = scope.keep(proj_crs_get_sub_crs(ctx, crs, 0));
  PJ* conversion =
      crs && proj_get_type(crs) == PJ_TYPE_PROJECTED_CRS ? scope.keep(proj_crs_get_coordoperation(ctx, crs)) : nullptr;
  PJ* lonlat_first = conversion ? scope.keep(proj_normalize_for_visualization(ctx, conversion)) : nullptr;
  PJ* ellipsoid = crs ? scope.keep(proj_get_ellipsoid(ctx, crs)) : nullptr;
  double a = 0, inverse_flattening = 0;
  if (lonlat_first && ellipsoid &&
      proj_ellipsoid_get_parameters(ctx, ellipsoid, &a, nullptr, nullptr, &inverse_flattening) && a > 0) {
    const PJ_COORD at = proj_trans(lonlat_first, PJ_INV, proj_coord(x, y, 0, 0));
    const double lon = at.xy.x, lat = at.xy.y, step = 1e-5;
    const PJ_COORD p = proj_trans(lonlat_first, PJ_FWD, proj_coord(lon, lat, 0, 0));
    const PJ_COORD north = proj_trans(lonlat_first, PJ_FWD, proj_coord(lon, lat + step, 0, 0));
    const PJ_COORD east = proj_trans(lonlat_first, PJ_FWD, proj_coord(lon + step, lat, 0, 0));
    const double f = inverse_flattening > 0 ? 1 / inverse_flattening : 0, e2 = f * (2 - f);
    const double phi = proj_torad(lat), w = 1 - e2 * std::sin(phi) * std::sin(phi);
    const double m = a * (1 - e2) / (w * std::sqrt(w)), n = a / std::sqrt(w);
    const double h = std::hypot(north.xy.x - p.xy.x, north.xy.y - p.xy.y) / (m * proj_torad(step));
    const double k = std::hypot(east.xy.x - p.xy.x, east.xy.y - p.xy.y) / (n * std::cos(phi) * proj_torad(step));
    if (std::isfinite(h) && std::isfinite(k) && std::abs(lat) < 89.9)
      departure = std::max(std::abs(h - 1), std::abs(k - 1));
  }
  return departure;
}

bool proven_metric(const Crs& crs, double x, double y, bool units_only) {
  const std::string& text = crs.wkt.empty() ? crs.definition : crs.wkt;
  if (text.empty() || crs.geographic) return false;
  // What the data itself says of its units (a raster band's unit type) counts as well.
  if (crs.linear_unit_m != 0 && !is_metre(crs.linear_unit_m)) return false;
  if (!crs.vertical_unit.empty() && !is_metre(crs.vertical_unit_m)) return false;
  ProjScope scope;
  PJ* whole = unbound(scope, scope.keep(proj_create(scope.ctx(), text.c_str())));
  if (!whole) return false;
  PJ* horizontal = whole;
  if (proj_get_type(whole) == PJ_TYPE_COMPOUND_CRS) {
    horizontal = unbound(scope, scope.keep(proj_crs_get_sub_crs(scope.ctx(), whole, 0)));
    PJ* vertical = unbound(scope, scope.keep(proj_crs_get_sub_crs(scope.ctx(), whole, 1)));
    if (!vertical || proj_get_type(vertical) != PJ_TYPE_VERTICAL_CRS || !axes_in_metres(scope, vertical)) return false;
  }
  if (!horizontal || proj_get_type(horizontal) != PJ_TYPE_PROJECTED_CRS || !axes_in_metres(scope, horizontal))
    return false;
  return units_only || !(scale_departure(text, x, y) > kMaxScaleDeparture);
}

}  // namespace dsmplan
