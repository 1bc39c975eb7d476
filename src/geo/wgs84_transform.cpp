// CRS coordinates to WGS84 longitude, latitude and height, through PROJ (proj.h), with the
// vertical part made explicit: the operation is the best one PROJ knows for the data's area
// whose grids are present (proj_create_operations with missing-grid operations discarded);
// when that is only a "ballpark" one (heights copied across datums, metres to tens of metres
// wrong: DHHN2016 to the ellipsoid is about 47 m at Muelheim), it is refused unless allowed.
// Allowed, the heights are taken as EGM96 heights (EPSG:5773) and go through the EGM96 grid
// (egm96_15.gtx, Debian's proj-data): a national height datum and EGM96 differ by the datum's
// offset and EGM96's own error, about a metre, never by the geoid's tens of metres.
// Axis order: proj_normalize_for_visualization, so longitude comes first whatever EPSG says.
#include <proj.h>
#include <proj_experimental.h>

#include <array>
#include <cmath>
#include <memory>
#include <string>

#include "dsmplan/wgs84.hpp"

namespace dsmplan {

namespace {

struct ContextDeleter {
  void operator()(PJ_CONTEXT* c) const { proj_context_destroy(c); }
};
struct PjDeleter {
  void operator()(PJ* p) const { proj_destroy(p); }
};
using Pj = std::unique_ptr<PJ, PjDeleter>;

std::string last_error(PJ_CONTEXT* ctx) {
  const int code = proj_context_errno(ctx);
  return code ? std::string(": ") + proj_context_errno_string(ctx, code) : std::string();
}

const char* target_code(HeightReference target) {
  switch (target) {
    case HeightReference::Ellipsoid:
      return "EPSG:4979";  // WGS 84 3D: ellipsoidal heights, as RFC 7946 GeoJSON states them
    case HeightReference::MeanSeaLevel:
      return "EPSG:4326+5773";  // WGS 84 + EGM96 height: the AMSL of MAVLink missions
  }
  return "EPSG:4979";
}

// The data's CRS as PROJ reads it (its WKT, else its definition).
Pj read_crs(PJ_CONTEXT* ctx, const Crs& crs) {
  const std::string text = !crs.wkt.empty() ? crs.wkt : crs.definition;
  if (text.empty()) throw ArgumentError("crs", "the data has no coordinate reference system");
  Pj source(proj_create(ctx, text.c_str()));
  if (!source) throw ArgumentError("crs", "PROJ cannot read the data's CRS" + last_error(ctx));
  return source;
}

// The first of the operations PROJ lists from `from` to `to` (sorted best first) over `area`
// (west, south, east, north; NaN = anywhere), grids used as `grids` says; null when none.
Pj first_operation(PJ_CONTEXT* ctx, PJ* from, PJ* to, const std::array<double, 4>& area,
                   PROJ_GRID_AVAILABILITY_USE grids) {
  PJ_OPERATION_FACTORY_CONTEXT* factory = proj_create_operation_factory_context(ctx, nullptr);
  proj_operation_factory_context_set_grid_availability_use(ctx, factory, grids);
  proj_operation_factory_context_set_spatial_criterion(ctx, factory, PROJ_SPATIAL_CRITERION_PARTIAL_INTERSECTION);
  if (std::isfinite(area[0]))
    proj_operation_factory_context_set_area_of_interest(ctx, factory, area[0], area[1], area[2], area[3]);
  PJ_OBJ_LIST* list = proj_create_operations(ctx, from, to, factory);
  proj_operation_factory_context_destroy(factory);
  Pj first(list && proj_list_get_count(list) > 0 ? proj_list_get(ctx, list, 0) : nullptr);
  if (list) proj_list_destroy(list);
  return first;
}

// The best operation whose grids are all installed; ArgumentError("crs") when there is none.
Pj best_operation(PJ_CONTEXT* ctx, PJ* from, PJ* to, const std::array<double, 4>& area) {
  Pj best = first_operation(ctx, from, to, area, PROJ_GRID_AVAILABILITY_DISCARD_OPERATION_IF_MISSING_GRID);
  if (!best) throw ArgumentError("crs", "PROJ has no transformation from the data's CRS to WGS 84" + last_error(ctx));
  return best;
}

}  // namespace

struct Wgs84Transform::State {
  std::unique_ptr<PJ_CONTEXT, ContextDeleter> ctx{proj_context_create()};
  Pj operation;
};

Wgs84Transform::~Wgs84Transform() = default;
Wgs84Transform::Wgs84Transform(Wgs84Transform&&) noexcept = default;

Wgs84Transform::Wgs84Transform(const Crs& crs, HeightReference target, const VerticalOptions& options,
                               const std::array<double, 4>& area)
    : state_(std::make_shared<State>()) {
  PJ_CONTEXT* ctx = state_->ctx.get();
  proj_log_level(ctx, PJ_LOG_NONE);
  Pj source = read_crs(ctx, crs);
  // Heights above the ellipsoid: a projected or geographic CRS with a third axis (ellipsoidal
  // height, as PROJ's promote_to_3D makes and GeoTIFF 1.1's VerticalGeoKey 4979 states).
  const auto three_axes = [&](PJ* crs) {
    const PJ_TYPE type = proj_get_type(crs);
    if (type != PJ_TYPE_PROJECTED_CRS && type != PJ_TYPE_GEOGRAPHIC_3D_CRS) return false;
    Pj cs(proj_crs_get_coordinate_system(ctx, crs));
    return cs && proj_cs_get_axis_count(ctx, cs.get()) == 3;
  };
  const bool ellipsoidal = three_axes(source.get());
  const bool has_vertical = proj_get_type(source.get()) == PJ_TYPE_COMPOUND_CRS || ellipsoidal;
  bool promoted = false;
  if (!has_vertical && !options.vertical_crs.empty()) {
    Pj vertical(proj_create(ctx, options.vertical_crs.c_str()));
    if (vertical && proj_get_type(vertical.get()) == PJ_TYPE_GEOGRAPHIC_3D_CRS) {
      // A geographic 3D CRS (EPSG:4979): the heights are ellipsoidal heights of its datum, which
      // must be the data's own (the CRS is made 3D, not transformed).
      Pj a(proj_crs_get_datum_forced(ctx, source.get())), b(proj_crs_get_datum_forced(ctx, vertical.get()));
      if (!a || !b || !proj_is_equivalent_to_with_ctx(ctx, a.get(), b.get(), PJ_COMP_EQUIVALENT))
        throw ArgumentError("vertical_crs",
                            "'" + options.vertical_crs + "' gives ellipsoidal heights of " +
                                (b && proj_get_name(b.get()) ? proj_get_name(b.get()) : "another datum") +
                                ", the data's datum is " +
                                (a && proj_get_name(a.get()) ? proj_get_name(a.get()) : "unknown"));
      source.reset(proj_crs_promote_to_3D(ctx, nullptr, source.get()));
      if (!source)
        throw ArgumentError("vertical_crs", "cannot make the data's CRS three-dimensional" + last_error(ctx));
      promoted = true;
    } else {
      if (!vertical || proj_get_type(vertical.get()) != PJ_TYPE_VERTICAL_CRS)
        throw ArgumentError("vertical_crs", "'" + options.vertical_crs +
                                                "' is not a vertical CRS PROJ knows (nor a geographic 3D CRS such as "
                                                "EPSG:4979 for ellipsoidal heights)");
      source.reset(proj_create_compound_crs(ctx, "data", source.get(), vertical.get()));
      if (!source) throw ArgumentError("vertical_crs", "cannot combine it with the data's CRS" + last_error(ctx));
    }
  }
  std::string why_egm96;  // set when the heights are taken as EGM96 heights
  if (!has_vertical && options.vertical_crs.empty()) {
    if (!options.allow_approximate_vertical)
      throw ArgumentError("vertical_crs",
                          "the data's vertical reference is unknown, so its heights cannot be converted; name it "
                          "(e.g. --vertical-crs EPSG:7837 for DHHN2016, EPSG:4979 for heights above the WGS 84 "
                          "ellipsoid as GNSS and satellite heights are) or, for heights above mean sea level only, "
                          "pass --allow-approximate-vertical to take them as EGM96 heights (about a metre off; "
                          "ellipsoidal heights would be off by the geoid's height, tens of metres)");
    why_egm96 = "the data's vertical reference is unknown";
  }
  Pj destination(proj_create(ctx, target_code(target)));
  if (!destination) throw ArgumentError("crs", "PROJ cannot build the WGS 84 target" + last_error(ctx));

  // The grids the best operation would use were every grid installed, those PROJ lacks: what
  // to install instead of a ballpark (e.g. "nl_nsgi_nlgeo2018.tif" for NAP, us_nga_egm08_25.tif
  // for EGM2008).
  const auto missing_grids = [&](PJ* from) {
    std::string names;
    const Pj ideal = first_operation(ctx, from, destination.get(), area, PROJ_GRID_AVAILABILITY_IGNORED);
    const int grids = ideal ? proj_coordoperation_get_grid_used_count(ctx, ideal.get()) : 0;
    for (int i = 0; i < grids; ++i) {
      const char *short_name = nullptr, *url = nullptr;
      int available = 0;
      if (proj_coordoperation_get_grid_used(ctx, ideal.get(), i, &short_name, nullptr, nullptr, &url, nullptr, nullptr,
                                            &available) &&
          !available && short_name)
        names +=
            (names.empty() ? "" : ", ") + std::string(short_name) + (url && *url ? " (" + std::string(url) + ")" : "");
    }
    return names;
  };
  Pj best;
  if (why_egm96.empty()) {
    best = best_operation(ctx, source.get(), destination.get(), area);
    if (proj_coordoperation_has_ballpark_transformation(ctx, best.get())) {
      const std::string name = proj_get_name(best.get()) ? proj_get_name(best.get()) : "unnamed";
      const std::string grids = missing_grids(source.get());
      if (!options.allow_approximate_vertical)
        throw ArgumentError("vertical_crs",
                            "PROJ has only an approximate (ballpark) height transformation here ('" + name +
                                "': heights copied across datums, off by the geoid's height, tens of metres); " +
                                (grids.empty() ? "install the datum's geoid grid"
                                               : "install PROJ's grid " + grids + " into its data folder") +
                                " or pass --allow-approximate-vertical to take the heights as EGM96 heights (mean "
                                "sea level, about a metre off)");
      Pj vertical(proj_crs_get_sub_crs(ctx, source.get(), 1));
      const char* datum = vertical ? proj_get_name(vertical.get()) : nullptr;
      why_egm96 = std::string("PROJ has no grid from ") + (datum ? datum : "the data's height datum") + " here" +
                  (grids.empty() ? "" : " (not installed: " + grids + ")");
    }
  }
  if (!why_egm96.empty()) {
    Pj horizontal(proj_get_type(source.get()) == PJ_TYPE_COMPOUND_CRS ? proj_crs_get_sub_crs(ctx, source.get(), 0)
                                                                      : proj_clone(ctx, source.get()));
    Pj egm96(proj_create(ctx, "EPSG:5773"));
    if (!horizontal || !egm96)
      throw ArgumentError("crs", "PROJ cannot build the EGM96 height reference" + last_error(ctx));
    source.reset(proj_create_compound_crs(ctx, "data as EGM96", horizontal.get(), egm96.get()));
    if (!source) throw ArgumentError("crs", "PROJ cannot combine the data's CRS with EGM96" + last_error(ctx));
    best = best_operation(ctx, source.get(), destination.get(), area);
    if (proj_coordoperation_has_ballpark_transformation(ctx, best.get()))
      throw ArgumentError("allow_approximate_vertical",
                          "PROJ has no EGM96 grid (egm96_15.gtx, Debian's proj-data) to take the heights through");
    approximate_ = true;
  }
  description_ = proj_get_name(best.get()) ? proj_get_name(best.get()) : "unnamed";
  if (approximate_) {
    description_ +=
        "; heights taken as EGM96 heights (mean sea level) because " + why_egm96 +
        " (approximate heights: off by the difference between the data's datum and EGM96, typically under "
        "1 m, never by the geoid's height) to " +
        (target == HeightReference::MeanSeaLevel ? "EGM96 height (mean sea level)" : "WGS 84 ellipsoidal height");
  } else {
    // PROJ's name leaves out a vertical step that is the identity (EGM96 to EGM96): say it.
    Pj vertical(proj_crs_get_sub_crs(ctx, source.get(), 1));
    Pj datum(ellipsoidal || promoted ? proj_crs_get_datum_forced(ctx, source.get()) : nullptr);
    const std::string ellipsoid_name =
        datum && proj_get_name(datum.get()) ? std::string(proj_get_name(datum.get())) + " ellipsoidal height" : "";
    const char* from = vertical                  ? proj_get_name(vertical.get())
                       : !ellipsoid_name.empty() ? ellipsoid_name.c_str()
                                                 : nullptr;
    description_ +=
        std::string("; heights from ") + (from ? from : "the data's vertical CRS") + " to " +
        (target == HeightReference::MeanSeaLevel ? "EGM96 height (mean sea level)" : "WGS 84 ellipsoidal height");
  }
  state_->operation.reset(proj_normalize_for_visualization(ctx, best.get()));
  if (!state_->operation) throw ArgumentError("crs", "PROJ cannot order the axes longitude first" + last_error(ctx));
}

Wgs84Transform Wgs84Transform::horizontal_only(const Crs& crs, const std::array<double, 4>& area) {
  Wgs84Transform t;
  t.state_ = std::make_shared<State>();
  PJ_CONTEXT* ctx = t.state_->ctx.get();
  proj_log_level(ctx, PJ_LOG_NONE);
  Pj source = read_crs(ctx, crs);
  if (proj_get_type(source.get()) == PJ_TYPE_COMPOUND_CRS) source.reset(proj_crs_get_sub_crs(ctx, source.get(), 0));
  if (source) source.reset(proj_crs_demote_to_2D(ctx, nullptr, source.get()));
  Pj destination(proj_create(ctx, "EPSG:4326"));
  if (!source || !destination)
    throw ArgumentError("crs", "PROJ cannot take the CRS's horizontal part" + last_error(ctx));
  const Pj best = best_operation(ctx, source.get(), destination.get(), area);
  t.description_ = std::string(proj_get_name(best.get()) ? proj_get_name(best.get()) : "unnamed") +
                   "; horizontal only (heights not transformed)";
  t.state_->operation.reset(proj_normalize_for_visualization(ctx, best.get()));
  if (!t.state_->operation) throw ArgumentError("crs", "PROJ cannot order the axes longitude first" + last_error(ctx));
  return t;
}

Point3 Wgs84Transform::apply(const Point3& p, bool forward) const {
  PJ_COORD c = proj_coord(p[0], p[1], p[2], 0);
  const PJ_COORD out = proj_trans(state_->operation.get(), forward ? PJ_FWD : PJ_INV, c);
  Point3 r{out.xyz.x, out.xyz.y, out.xyz.z};
  for (double v : r)
    if (!std::isfinite(v))
      throw ArgumentError("crs", "PROJ cannot transform the point (" + std::to_string(p[0]) + ", " +
                                     std::to_string(p[1]) + ", " + std::to_string(p[2]) + ")");
  return r;
}

void Wgs84Transform::from_wgs84(std::vector<Point3>& points) const {
  if (points.empty()) return;
  constexpr size_t stride = sizeof(Point3);
  proj_trans_generic(state_->operation.get(), PJ_INV, &points[0][0], stride, points.size(), &points[0][1], stride,
                     points.size(), &points[0][2], stride, points.size(), nullptr, 0, 0);
  for (Point3& p : points)
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) p = {NAN, NAN, NAN};
}

}  // namespace dsmplan
