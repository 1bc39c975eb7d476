// Planning over a tiled city along a corridor (see dsmplan/corridor.hpp): each
// leg cut into pieces, each piece planned by the PRM of plan_path() (Kavraki, Svestka, Latombe
// & Overmars 1996) on the conservative bounded mesh of its own window of the DSM, read from the
// GridSource window by window, so that a city never has to be meshed or held whole.
#include "dsmplan/corridor.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include "dsmplan/columns.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/simplify_streamed.hpp"
#include "plan/path_parts.hpp"

namespace dsmplan {

using detail::format_number;

namespace {

struct Window {
  std::unique_ptr<FlightArea> area;  // the window's DSM (holes left), its mesh and index
  VerticalError error;               // the mesh against the DSM, certified by simplify_bounded()
};

// The flight area (x,y box of the piece's ends, widened by margin, clipped to the DSM's cell
// centres) and its mesh, made of the area widened by `pad` more.
// `common`: what every window's data shares (the names, the terrain, the zones).
std::unique_ptr<Window> make_window(GridSource& source, const Point3& a, const Point3& b, double margin, double pad,
                                    const BoundedSimplifyOptions& simplify, const FlightData& common) {
  const Grid& frame = source.frame();
  const double left = frame.center_x(0), right = frame.center_x(frame.width - 1);
  const double top = frame.center_y(0), bottom = frame.center_y(frame.height - 1);
  const std::array<double, 4> area{
      std::max(left, std::min(a[0], b[0]) - margin), std::max(bottom, std::min(a[1], b[1]) - margin),
      std::min(right, std::max(a[0], b[0]) + margin), std::min(top, std::max(a[1], b[1]) + margin)};
  auto clamp_col = [&](double x) {
    return std::clamp(static_cast<int>(std::floor((x - frame.x0) / frame.cell_x)), 0, frame.width - 1);
  };
  auto clamp_row = [&](double y) {
    return std::clamp(static_cast<int>(std::floor((frame.y0 - y) / frame.cell_y)), 0, frame.height - 1);
  };
  const int c0 = clamp_col(area[0] - pad), c1 = clamp_col(area[2] + pad);
  const int r0 = clamp_row(area[3] + pad), r1 = clamp_row(area[1] - pad);
  auto window = std::make_unique<Window>();
  FlightData data = common;
  data.dsm = std::make_shared<const Grid>(read_window(source, c0, r0, c1 - c0 + 1, r1 - r0 + 1));
  // Holes are unknown space, as high as their rim (as far as the window shows it), meshed as
  // columns like any other; the mesh is conservative (never below a cell centre).
  Grid filled = *data.dsm;
  fill_holes_from_rim(filled, RimHeight::highest);
  data.mesh_fills_holes = true;
  BoundedSimplifyOptions mesh_options = simplify;
  mesh_options.conservative = true;
  GridView view(filled);
  auto mesh = std::make_shared<Mesh>();
  mesh->crs = frame.crs;
  MeshCollector collector(*mesh);
  window->error = simplify_bounded(view, mesh_options, collector).error;
  // The index covers the flight area only: nothing flies outside it.
  ClearanceOptions clearance;
  clearance.flight_area = area;
  data.index = std::make_shared<const ClearanceIndex>(std::shared_ptr<const Mesh>(mesh), clearance);
  data.mesh = std::move(mesh);
  window->area = std::make_unique<FlightArea>(std::move(data));
  return window;
}

}  // namespace

CorridorResult plan_corridor(GridSource& dsm, const std::vector<Point3>& waypoints, const PlanOptions& plan,
                             const CorridorOptions& options, const Progress& progress, const FlightNames& names,
                             const std::vector<AirspaceZone>& zones, const AirspaceOptions& airspace) {
  if (!(options.chunk > 0) || !std::isfinite(options.chunk))
    throw ArgumentError("chunk", "must be a positive length, got " + format_number(options.chunk));
  if (!(options.margin > 0) || !std::isfinite(options.margin))
    throw ArgumentError("margin", "must be a positive length, got " + format_number(options.margin));
  check_bounded_options(options.mesh);
  if (waypoints.size() < 2) throw ArgumentError("waypoints", "a path needs at least two");
  const Grid& frame = dsm.frame();
  const double cap = plan.safety + plan.max_agl;
  CorridorResult out;
  out.min_clearance_m = out.min_clearance_dsm_m = cap;
  PlanResult& result = out.plan;

  const double left = frame.center_x(0), right = frame.center_x(frame.width - 1);
  const double top = frame.center_y(0), bottom = frame.center_y(frame.height - 1);
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const Point3& w = waypoints[i];
    if (!std::isfinite(w[0]) || !std::isfinite(w[1]) || !std::isfinite(w[2]))
      throw ArgumentError("waypoints", "waypoint " + std::to_string(i + 1) + " is not finite");
    if (w[0] < left || w[0] > right || w[1] < bottom || w[1] > top) {
      result.status = PlanStatus::InvalidWaypoint;
      result.waypoint = i;
      result.reason = "outside the DSM's extent (x " + format_number(left) + " to " + format_number(right) + ", y " +
                      format_number(bottom) + " to " + format_number(top) + ")";
      return out;
    }
  }

  // Stops: the waypoints, with via points cutting each leg into pieces of at most `chunk`.
  std::vector<Point3> stops;
  std::vector<size_t> leg_of_piece;
  std::vector<bool> via;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    const Point3 &a = waypoints[i], &b = waypoints[i + 1];
    const size_t pieces = std::max<size_t>(1, size_t(std::ceil(std::hypot(b[0] - a[0], b[1] - a[1]) / options.chunk)));
    for (size_t k = 0; k < pieces; ++k) {
      const double t = double(k) / double(pieces);
      stops.push_back({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), k == 0 ? a[2] : NAN});
      via.push_back(k != 0);
      leg_of_piece.push_back(i);
    }
  }
  stops.push_back(waypoints.back());
  via.push_back(false);
  const size_t pieces = stops.size() - 1;

  const double pad = plan.safety + 2 * std::max(frame.cell_x, frame.cell_y);
  FlightData common;
  common.terrain = options.terrain;
  common.names = names;
  common.no_fly = zones;
  common.airspace = airspace;
  auto window_for = [&](size_t k) {
    const auto start = std::chrono::steady_clock::now();
    auto window = make_window(dsm, stops[k], stops[k + 1], options.margin, pad, options.mesh, common);
    out.seconds_windows += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return window;
  };
  std::unique_ptr<Window> current = window_for(0), next;
  for (size_t k = 0; k < pieces; ++k) {
    if (k + 1 < pieces) next = window_for(k + 1);
    const size_t leg = leg_of_piece[k];
    if (via[k + 1]) {
      // The lowest whole-metre height above safety over both surfaces that both windows allow.
      Point3& p = stops[k + 1];
      const FlightArea &here_area = *current->area, &there_area = *next->area;
      const double g0 = here_area.index().ground(p[0], p[1]), g1 = there_area.index().ground(p[0], p[1]);
      const PlanOptions here_plan = here_area.planner_options(plan), there_plan = there_area.planner_options(plan);
      const FlightSpace here = detail::flight_space(here_area.index(), here_plan),
                        there = detail::flight_space(there_area.index(), there_plan);
      const double ceiling = std::min(here.ceiling_at(p[0], p[1]), there.ceiling_at(p[0], p[1]));
      bool placed = false;
      for (double z = std::max(g0, g1) + plan.safety; !placed && z <= ceiling; z += 1) {
        p[2] = z;
        placed = here.state_valid(p) && there.state_valid(p);
      }
      if (!placed) {
        result.status = PlanStatus::NoPath;
        result.waypoint = leg;
        result.reason = "no safe via point at x " + format_number(p[0]) + " y " + format_number(p[1]) +
                        " (where the leg's windows meet) under --max-agl";
        return out;
      }
    }
    // The piece is a flight of its own over its window: held to every rule and verified there.
    FlightQuery piece_query;
    piece_query.waypoints = {stops[k], stops[k + 1]};
    piece_query.options = plan;
    piece_query.straight_legs = options.straight_legs;
    const FlightAttempt piece =
        attempt_flight(*current->area, piece_query, sub_progress(progress, double(k) / pieces, double(k + 1) / pieces));
    const FlightReport& figures = piece.plan.report;
    result.roadmap_nodes += figures.roadmap_nodes;
    result.roadmap_edges += figures.roadmap_edges;
    result.seconds_roadmap += figures.seconds_roadmap;
    result.seconds_query += figures.seconds_query;
    result.seconds_smooth += figures.seconds_smooth;
    result.refined_samples += figures.refined_samples;
    if (!piece.solved) {
      const PlanResult& failed = piece.failure;
      result.status = failed.status;
      const bool end = failed.status == PlanStatus::InvalidWaypoint && failed.waypoint == 1;
      const bool at_via = failed.status == PlanStatus::InvalidWaypoint && via[k + end];
      result.waypoint = failed.status == PlanStatus::InvalidWaypoint && !at_via ? leg + end : leg;
      if (at_via) result.status = PlanStatus::NoPath;
      result.reason =
          (at_via ? "via point of the leg: " : "") + failed.reason +
          (failed.status == PlanStatus::NoPath ? " (piece " + std::to_string(k + 1) + " of the corridor)" : "");
      return out;
    }
    const std::vector<Point3>& path = piece.plan.path;
    // Not measured on a window (freespace over the DSM's columns plans without the mesh): not
    // measured at all, rather than the cap.
    out.min_clearance_m =
        std::isnan(figures.min_clearance_m) ? NAN : std::min(out.min_clearance_m, figures.min_clearance_m);
    out.min_clearance_dsm_m = std::min(out.min_clearance_dsm_m, figures.min_clearance_dsm_m);
    out.max_agl_m = std::max(out.max_agl_m, figures.max_agl_m);
    if (out.no_fly_zones.empty()) out.no_fly_zones = figures.no_fly_zones;
    for (size_t z = 0; z < out.no_fly_zones.size(); ++z)
      out.no_fly_zones[z].min_distance_m =
          std::min(out.no_fly_zones[z].min_distance_m, figures.no_fly_zones[z].min_distance_m);
    const size_t skip = result.path.empty() ? 0 : 1;  // the joint is the previous piece's end
    result.path.insert(result.path.end(), path.begin() + skip, path.end());
    out.mesh_error.merge(current->error);
    if (!std::isnan(figures.safety_margin_m))  // measured only when the planner used the mesh
      out.safety_margin_m = std::max(out.safety_margin_m, current->area->safety_margin());
    out.largest_window_cells = std::max(out.largest_window_cells, current->area->data().dsm->cells());
    ++out.windows;
    current = std::move(next);
  }
  result.status = PlanStatus::Solved;
  report(progress, 1);
  return out;
}

}  // namespace dsmplan
