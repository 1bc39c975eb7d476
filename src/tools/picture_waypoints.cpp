// read_picture_waypoints(): the waypoint file of a picture (render, profile, view) read as
// `dsmplan plan` reads it, so that a waypoint is drawn where the plan flies it.
#include "dsmplan/flight.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/waypoints.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

std::vector<Point3> read_picture_waypoints(const std::string& path, const std::function<const Grid*()>& ground_of,
                                           const std::string& ground_name, const std::string& give_ground) {
  bool agl = false;
  std::vector<Point3> waypoints = read_waypoints_csv(path, &agl);
  if (!agl) return waypoints;
  const Grid* ground = ground_of();
  if (!ground)
    throw InputError(path, "line 1",
                     "its header names the height column agl (heights above the ground): " + give_ground +
                         " to measure them from, as dsmplan plan does");
  // The ground as the plan counts it (GroundGrid: holes at their rim's lowest), the same heights.
  const GroundGrid measured(*ground);
  return waypoints_in_crs(
      std::move(waypoints), WaypointHeights::agl,
      [&](double x, double y) {
        return -measured.height_above({x, y, 0});
      },
      path, ground_name);
}

}  // namespace dsmplan
