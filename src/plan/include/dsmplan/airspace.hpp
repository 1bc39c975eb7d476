// dsmplan/airspace.hpp: the no-fly zones authorities publish (UAS geographical zones), as the
// planner's constraints; part of stage 4 (plan.hpp). No GDAL or PROJ here: the reader that turns
// an ED-269 or GeoJSON file into AirspaceZones in the mesh's CRS is read_airspace()
// (airspace_io.hpp, in dsmplan_geo).
//
// A zone's volume: the points (x, y, z) whose x, y lie in its area (the rings by the even-odd
// rule: the outer ring, less its holes; boundaries included; either orientation) and whose z
// lies between its lower and upper limit, each
//   - a height above the ground (AGL): the GroundGrid's cell under (x, y) (the DTM, else the
//     DSM), on a line between cells the lowest touching cell for a floor and the highest for a
//     ceiling (the larger volume); where the ground is unknown (no GroundGrid, or beyond its
//     raster) a floor reaches down without end and a ceiling up without end;
//   - a height in the mesh's CRS (the reader converted AMSL and WGS 84 heights, and feet);
//   - or unlimited: a lower limit from below the ground, an upper one with no top.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/flight_space.hpp"
#include "dsmplan/ground.hpp"

namespace dsmplan {

/// A lower or upper limit of a zone: a height in metres with what it counts from.
struct ZoneLimit {
  enum class Reference {
    unlimited,     ///< lower: from below the ground; upper: no top (`height` unused)
    above_ground,  ///< `height` metres above the ground (GroundGrid)
    crs            ///< `height` is a height in the mesh's CRS, in its vertical reference
  };
  Reference reference = Reference::unlimited;
  double height = 0;

  static ZoneLimit none() { return {}; }
  static ZoneLimit agl(double metres) { return {Reference::above_ground, metres}; }
  static ZoneLimit crs_height(double z) { return {Reference::crs, z}; }
};

/// One zone (an ED-269 feature's volume, or a GeoJSON polygon) in the mesh's CRS.
struct AirspaceZone {
  std::string id;           ///< the file's identifier ("" when it gave none)
  std::string name;         ///< the file's name ("" when it gave none)
  std::string restriction;  ///< ED-269: PROHIBITED, REQ_AUTHORISATION, CONDITIONAL, NO_RESTRICTION
  std::string source_file;  ///< the file it was read from, for messages
  /// Outer ring first, then its holes; x, y in the mesh's CRS; closed or not.
  std::vector<std::vector<std::array<double, 2>>> rings;
  ZoneLimit lower, upper;
};

/// How messages name a zone: "zone 'NAME' (ID) of FILE"; "zone 'ID' of FILE" without a name,
/// "zone of FILE" with neither, no " of FILE" without a source file.
std::string zone_label(const AirspaceZone& zone);

/// ArgumentError("no_fly") naming the zone (zone_label()) when a ring has fewer than 3 corners
/// (a closing corner equal to the first does not count), a corner or a height is not finite,
/// there is no ring, or both limits have the same reference and lower > upper.
void check_zone(const AirspaceZone& zone);

/// Which restrictions keep the drone out. ED-269's values are PROHIBITED, REQ_AUTHORISATION,
/// CONDITIONAL and NO_RESTRICTION; by default the first two block (an authorisation the
/// planner cannot know was granted), the last two are shown, not avoided.
struct AirspaceOptions {
  std::vector<std::string> blocking = {"PROHIBITED", "REQ_AUTHORISATION"};
};
/// ED-269's four restrictions, in its order.
const std::vector<std::string>& zone_restrictions();
/// AirspaceOptions::blocking = {"NONE"}: no zone blocks, every one is drawn, none avoided.
constexpr const char* kNoZoneBlocks = "NONE";
/// ArgumentError("no_fly_blocking") unless options.blocking is {kNoZoneBlocks}, or names at
/// least one restriction and every entry is one of zone_restrictions() (exact, with the nearest
/// name for a typo): a value no zone can have would silently unblock the zones it was meant to
/// name.
void check_airspace_options(const AirspaceOptions& options);
/// True when the zone's restriction is one of options.blocking (exact, case-sensitive). Checks
/// the options first (check_airspace_options()): every face's answer to "does it block" goes
/// through here.
bool zone_blocks(const AirspaceZone& zone, const AirspaceOptions& options = {});

/// True when `p` (CRS) lies in the zone's volume, boundary included, with no safety distance:
/// the test a waypoint, home or landing fails. `ground` counts the AGL limits (null: unknown,
/// see the top). O(corners).
bool zone_contains(const AirspaceZone& zone, const Point3& p, const GroundGrid* ground);

/// True when `path` (CRS), seen from above, meets one of the zone's rings, each ring taken by
/// itself (its edges or its inside, a hole's ring too), whatever the heights: a flat fence of the
/// zone's rings (a mission's geofence) would be breached by it. O(path points x corners).
bool path_meets_zone_rings(const AirspaceZone& zone, const std::vector<Point3>& path);

/// A zone kept at `safety` metres, as a FlightConstraint (flight_space.hpp): a point or motion is
/// refused when it comes within `safety` of the zone's volume, horizontally or vertically:
///   - horizontally, within `safety` of the area (exact: the segment is cut where it enters and
///     leaves the disc-ended strip of width 2 safety around each edge, and the pieces between
///     are inside the area or not as a whole; holes shrink by the same rule);
///   - vertically, between lower - safety and upper + safety, an AGL limit counted from the
///     ground's envelope: a floor from the lowest cell within safety + 2 cells around, a
///     ceiling from the highest (van Herk / Gil-Werman), so a point safety metres beside a
///     zone's floor is refused however the ground steps between them. Each piece of the
///     segment over the area is refused when its greatest height above the floor's envelope
///     reaches the floor and its least height above the ceiling's reaches the ceiling
///     (GroundGrid::max_height_above(), exact over cells); both asked of the whole piece, so
///     a piece that passes a floor and a ceiling of AGL at different points is refused too.
/// Conservative, never optimistic: every point within `safety` (Euclidean, 3D) of the volume is
/// refused; refused too are some points up to safety * sqrt(2) away (diagonally from an edge of
/// the volume) and 1e-6 m more everywhere (rounding). Deterministic, thread-safe (immutable).
/// Holds `ground`; its envelope covers the zone's x, y box plus safety (O(those cells) memory,
/// made once). ArgumentError("no_fly") as check_zone(), ArgumentError("safety") for a negative
/// or not finite safety. motion_valid() O(corners + ground cells crossed over the area).
class AirspaceConstraint : public FlightConstraint {
public:
  /// `asked`, when given: the box (xmin, ymin, xmax, ymax, CRS) holding every point the
  /// constraint will be asked about; the AGL envelopes are then made over it alone (a zone far
  /// from a path needs only its near side: zone_distance()). Points beyond it are refused.
  AirspaceConstraint(AirspaceZone zone, double safety, std::shared_ptr<const GroundGrid> ground,
                     const std::array<double, 4>* asked = nullptr);
  ~AirspaceConstraint() override;
  bool state_valid(const Point3& p) const override;
  bool motion_valid(const Point3& p, const Point3& q) const override;
  /// "no-fly zone 'NAME' (ID) of FILE" (zone_label()).
  std::string name() const override;
  const AirspaceZone& zone() const;
  double safety() const;
  /// The x, y box (xmin, ymin, xmax, ymax, CRS) outside which every point and motion is allowed:
  /// the zone's, widened by the safety distance.
  std::array<double, 4> box() const;

private:
  struct State;
  std::unique_ptr<const State> state_;
};

/// Many zones as one FlightConstraint: each point or motion is tested against the zones whose
/// box() it reaches only, found through a uniform grid of their boxes (cells about the size of a
/// zone), so a check costs what the zones near it cost, whatever their number (20,000 zones: the
/// same path as with the zones one by one, issue 49). The same answers as its members asked one
/// by one; refused_by() names the member. Thread-safe (immutable).
class ZoneSet : public FlightConstraint {
public:
  explicit ZoneSet(std::vector<std::shared_ptr<const AirspaceConstraint>> zones);
  ~ZoneSet() override;
  bool state_valid(const Point3& p) const override;
  bool motion_valid(const Point3& p, const Point3& q) const override;
  /// "N no-fly zones".
  std::string name() const override;
  const FlightConstraint* refused_by(const Point3& p, const Point3& q) const override;
  const std::vector<std::shared_ptr<const AirspaceConstraint>>& zones() const;

private:
  struct Grid;
  std::unique_ptr<const Grid> grid_;
};

/// One AirspaceConstraint at `safety` for each zone that blocks (zone_blocks()), in order, or
/// past kZoneSetFrom zones one ZoneSet of them all; what PlanOptions::constraints takes. Errors
/// as AirspaceConstraint.
constexpr size_t kZoneSetFrom = 16;
std::vector<std::shared_ptr<const FlightConstraint>> airspace_constraints(const std::vector<AirspaceZone>& zones,
                                                                          double safety,
                                                                          std::shared_ptr<const GroundGrid> ground,
                                                                          const AirspaceOptions& options = {});

/// The least distance from the path (its straight segments, CRS) to the zone's volume, metres:
/// 0 when the path enters it; for --stats. A guaranteed lower bound, found by bisection to 1 cm
/// or 1 % of the distance on AirspaceConstraint's motion_valid(): the largest distance d such
/// that the constraint at safety d lets every segment pass, so the true 3D distance is at least
/// the result, and at most sqrt(2) times it (+1 cm or 1 %) where the nearest approach is diagonal to an edge of the
/// volume (exact when it is straight beside or above it). +infinity for an empty path; capped
/// at 100 km. A zone without vertical limits gets its horizontal distance to the path, the exact
/// distance. Other zones 10 m or more away get a lower bound made of each segment's horizontal
/// distance and its height gap to the lowest floor (highest ceiling) the zone has over its area
/// (not within sqrt(2) then; a figure to read, the constraint keeps the distance); nearer ones
/// are bisected as above, the envelopes made over the path's box alone. O(path x corners + bisection steps x
/// (the envelope near the path + path x corners)).
double zone_distance(const AirspaceZone& zone, const std::vector<Point3>& path, const GroundGrid* ground);

}  // namespace dsmplan
