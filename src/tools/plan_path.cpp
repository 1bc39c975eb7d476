// dsmplan plan: a collision-free path through waypoints over an obstacle mesh, by the paper's
// planner (Adolf & Hirschmueller, Section 5: a Halton PRM with a 2 m safety distance), with the
// path's clearance measured afresh on the written points.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "dsmplan/export.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/tools.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

namespace {

std::string trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// Three comma-separated finite numbers, or false.
bool parse_point(const std::string& line, Point3& p) {
  size_t begin = 0;
  for (int k = 0; k < 3; ++k) {
    const size_t end = k < 2 ? line.find(',', begin) : line.size();
    if (end == std::string::npos) return false;
    const std::string field = trim(line.substr(begin, end - begin));
    const char* first = field.data() + (field.size() > 1 && field[0] == '+' ? 1 : 0);
    const auto [ptr, ec] = std::from_chars(first, field.data() + field.size(), p[k]);
    if (field.empty() || ec != std::errc() || ptr != field.data() + field.size() || !std::isfinite(p[k])) return false;
    begin = end + 1;
  }
  return true;
}

std::string shortest(double v) {
  char buffer[32];
  const auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof buffer, v);
  return std::string(buffer, ec == std::errc() ? ptr : buffer);
}

bool ends_with_csv(std::string path) {
  std::transform(path.begin(), path.end(), path.begin(), [](unsigned char c) { return std::tolower(c); });
  return path.size() >= 4 && path.compare(path.size() - 4, 4, ".csv") == 0;
}

}  // namespace

std::vector<Point3> read_waypoints_csv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the waypoint file");
  std::vector<Point3> points;
  std::string line;
  bool first = true;
  for (size_t number = 1; std::getline(in, line); ++number) {
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    Point3 p;
    if (parse_point(text, p)) {
      points.push_back(p);
    } else if (!first || std::any_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); })) {
      throw InputError(path, "line " + std::to_string(number),
                       "expected 'x,y,z' (three numbers), got '" + text.substr(0, 60) + "'");
    }
    first = false;
  }
  if (in.bad()) throw InputError(path, "", "cannot read the waypoint file");
  return points;
}

PlanReport plan_job(const PlanJobOptions& options, const Progress& progress) {
  if (!ends_with_csv(options.output))
    throw ArgumentError("-o", "the path is written as CSV: the name must end in .csv, got '" + options.output + "'");
  check_plan_options(options.plan);
  PlanReport report;
  report.mesh = options.mesh;
  report.waypoints = options.waypoints;
  report.output = options.output;

  const std::vector<Point3> waypoints = read_waypoints_csv(options.waypoints);
  report.waypoint_count = waypoints.size();
  if (waypoints.size() < 2)
    throw InputError(options.waypoints, "",
                     "a path needs at least two waypoints, the file has " + std::to_string(waypoints.size()));

  Stopwatch clock;
  const Mesh mesh = read_mesh(options.mesh, sub_progress(progress, 0, 0.2));
  require_projected(mesh.crs, options.mesh);
  if (mesh.triangles.empty()) throw InputError(options.mesh, "", "the mesh has no triangles");
  const ClearanceIndex index(mesh);
  report.seconds_load = clock.lap();

  const PlanResult result = plan_path(index, waypoints, options.plan, sub_progress(progress, 0.2, 0.95));
  report.roadmap_nodes = result.roadmap_nodes;
  report.roadmap_edges = result.roadmap_edges;
  report.seconds_roadmap = result.seconds_roadmap;
  report.seconds_query = result.seconds_query;
  report.seconds_smooth = result.seconds_smooth;
  if (result.status != PlanStatus::Solved) throw InputError(options.waypoints, result.place(), result.reason);

  report.path_points = result.path.size();
  report.path_length_m = path_length(result.path);
  // Measured on its own, not taken from the planner: the number a user checks the path by.
  const double cap = options.plan.safety + options.plan.max_agl;
  report.min_clearance_m = cap;
  for (size_t k = 1; k < result.path.size(); ++k)
    report.min_clearance_m = std::min(report.min_clearance_m, index.clearance(result.path[k - 1], result.path[k], cap));

  std::string text = "x,y,z\n";
  for (const Point3& p : result.path) text += shortest(p[0]) + "," + shortest(p[1]) + "," + shortest(p[2]) + "\n";
  write_text_file(options.output, text);
  dsmplan::report(progress, 1);
  return report;
}

Json to_json(const PlanReport& r) {
  Json j;
  j["path_length_m"] = r.path_length_m;
  j["min_clearance_m"] = r.min_clearance_m;
  j["roadmap_nodes"] = r.roadmap_nodes;
  j["roadmap_edges"] = r.roadmap_edges;
  j["seconds_load"] = r.seconds_load;
  j["seconds_roadmap"] = r.seconds_roadmap;
  j["seconds_query"] = r.seconds_query;
  j["seconds_smooth"] = r.seconds_smooth;
  return j;
}

std::string to_text(const PlanReport& r) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "%s: %zu points, %.1f m, min clearance %.2f m; roadmap %zu nodes, %zu edges "
                "(%.2f s), query %.3f s, smoothing %.3f s\n",
                r.output.c_str(), r.path_points, r.path_length_m, r.min_clearance_m, r.roadmap_nodes, r.roadmap_edges,
                r.seconds_roadmap, r.seconds_query, r.seconds_smooth);
  return buffer;
}

}  // namespace dsmplan
