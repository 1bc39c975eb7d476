// The rules a flight's straight motions are held to, and the measures of a path, each written
// once (flight.hpp): plan_flight()'s checks and verification, `dsmplan profile` and Python use them.
#include <cmath>

#include "dsmplan/columns.hpp"
#include "dsmplan/flight.hpp"

namespace dsmplan {

double ColumnsClearance::clearance(const Point3& p, const Point3& q) const {
  return column_clearance(columns_, p, q, safety());
}

double MeshClearance::clearance(const Point3& p, const Point3& q) const { return index_.clearance(p, q, safety()); }

bool FlightRules::keeps(const Point3& p, const Point3& q) const {
  check_stop(stop);
  if (ground && std::isfinite(max_agl) && !ground->below_ceiling(p, q, max_agl)) return false;
  for (const FlightConstraint* constraint : constraints)
    if (!constraint->motion_valid(p, q)) return false;
  return obstacles->motion_valid(p, q);
}

PathMeasures measure_path(const std::vector<Point3>& path, const GroundGrid& ground, const Grid* columns, double cap) {
  PathMeasures m;
  for (size_t k = 1; k < path.size(); ++k) {
    const double above = ground.max_height_above(path[k - 1], path[k]);
    if (above > m.max_agl_m) m.max_agl_m = above, m.max_agl_segment = k;
  }
  if (columns) {
    m.min_clearance_dsm_m = cap;
    for (size_t k = 1; k < path.size(); ++k) {
      // Measured up to the least so far: the same minimum, without searching far around every segment.
      const double d = column_clearance(*columns, path[k - 1], path[k], m.min_clearance_dsm_m);
      if (d < m.min_clearance_dsm_m) m.min_clearance_dsm_m = d, m.min_clearance_dsm_segment = k;
    }
  }
  return m;
}

}  // namespace dsmplan
