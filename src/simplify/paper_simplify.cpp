// The one-pass simplification of Adolf & Hirschmueller, "Meshing and Simplification of High
// Resolution Urban Surface Data for UAV Path Planning", Section 4 (variants one and two), with
// the readings documented in dsmplan/simplify.hpp. The half-edge circulation of the paper is
// replaced by its equivalent on a triangle soup: per vertex, the (next, previous) pair of every
// triangle corner at it; the corners' union is the one-ring, and an edge a->n whose reverse
// n->a is in no triangle lies on the border. Re-triangulation: CGAL's constrained Delaunay
// triangulation (Chew 1989) with the input's border edges as constraints, faces kept by the
// even-odd nesting of the border loops (as in CGAL's polygon-triangulation example).
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <list>
#include <string>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/simplify.hpp"

namespace dsmplan {

namespace {

constexpr uint32_t none = std::numeric_limits<uint32_t>::max();

// Heights in 0.1 m steps are decimals held in binary: 112.7 - 112.3 is 0.4000000000000057. The
// tolerances are compared with this much slack, so "within 0.4 m" means it at every height.
constexpr double height_slack = 1e-9;

// Per vertex, the corners of its triangles as (next, previous) vertex, counter-clockwise.
struct Corners {
  std::vector<uint32_t> begin;                      // CSR offsets, vertices + 1
  std::vector<std::pair<uint32_t, uint32_t>> list;  // (next, previous)

  explicit Corners(const Mesh& mesh) : begin(mesh.vertices.size() + 1, 0), list(3 * mesh.triangles.size()) {
    for (const Triangle& t : mesh.triangles)
      for (uint32_t v : t) ++begin[v + 1];
    for (size_t v = 0; v < mesh.vertices.size(); ++v) begin[v + 1] += begin[v];
    std::vector<uint32_t> fill(begin.begin(), begin.end() - 1);
    for (const Triangle& t : mesh.triangles)
      for (int k = 0; k < 3; ++k) list[fill[t[k]]++] = {t[(k + 1) % 3], t[(k + 2) % 3]};
  }
};

// The one-ring of a vertex, and its border neighbours when it lies on the border.
struct Ring {
  std::vector<uint32_t> neighbours;
  std::vector<uint32_t> border_next, border_previous;  // ends of border edges a->n and p->a

  void gather(const Corners& corners, uint32_t a) {
    neighbours.clear();
    border_next.clear();
    border_previous.clear();
    const auto first = corners.list.begin() + corners.begin[a], last = corners.list.begin() + corners.begin[a + 1];
    for (auto c = first; c != last; ++c) {
      neighbours.push_back(c->first);
      neighbours.push_back(c->second);
      // a->next is a border edge when no corner at a has `next` as its previous vertex.
      if (std::none_of(first, last, [&](const auto& d) { return d.second == c->first; }))
        border_next.push_back(c->first);
      if (std::none_of(first, last, [&](const auto& d) { return d.first == c->second; }))
        border_previous.push_back(c->second);
    }
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
  }
  bool on_border() const { return !border_next.empty(); }
};

double distance(const Vertex& p, const Vertex& q) {
  return std::sqrt(std::pow(p.x - q.x, 2) + std::pow(p.y - q.y, 2) + std::pow(p.z - q.z, 2));
}

class Marker {
public:
  Marker(const Mesh& mesh, const PaperSimplifyOptions& options) : mesh_(mesh), options_(options) {}

  bool coplanar(uint32_t a, const Ring& ring) const {
    if (ring.on_border()) return false;
    const double z = mesh_.vertices[a].z;
    return std::all_of(ring.neighbours.begin(), ring.neighbours.end(),
                       [&](uint32_t n) { return std::abs(mesh_.vertices[n].z - z) <= options_.dz + height_slack; });
  }

  bool colinear(uint32_t a, const Ring& ring) const {
    if (ring.on_border()) {
      // Only along the outline, so the footprint keeps its shape: on the x,y line between its
      // border neighbours too, whatever dco allows in 3D (dco 1 on 1 m cells cut corners of the
      // outline, and the vertices there were left outside every triangle: fuzz_pipeline).
      return ring.border_next.size() == 1 && ring.border_previous.size() == 1 &&
             on_line_xy(a, ring.border_previous[0], ring.border_next[0]) &&
             between(a, ring.border_previous[0], ring.border_next[0]);
    }
    const auto& n = ring.neighbours;
    for (size_t i = 0; i < n.size(); ++i)
      for (size_t j = i + 1; j < n.size(); ++j)
        if (between(a, n[i], n[j])) return true;
    return false;
  }

private:
  // A strictly between B and C in x,y, up to the rounding of CRS coordinates.
  bool on_line_xy(uint32_t a, uint32_t b, uint32_t c) const {
    const Vertex &A = mesh_.vertices[a], &B = mesh_.vertices[b], &C = mesh_.vertices[c];
    const double bx = B.x - A.x, by = B.y - A.y, cx = C.x - A.x, cy = C.y - A.y;
    return std::abs(bx * cy - cx * by) <= 1e-9 * std::hypot(bx, by) * std::hypot(cx, cy) && bx * cx + by * cy < 0;
  }

  bool between(uint32_t a, uint32_t b, uint32_t c) const {
    const Vertex &A = mesh_.vertices[a], &B = mesh_.vertices[b], &C = mesh_.vertices[c];
    if (options_.variant == PaperVariant::Two && std::abs(B.z - C.z) <= options_.dco) return false;
    return distance(A, B) + distance(A, C) <= distance(B, C) + options_.dco;
  }

  const Mesh& mesh_;
  const PaperSimplifyOptions& options_;
};

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<uint32_t, Kernel>;
using FaceBase =
    CGAL::Triangulation_face_base_with_info_2<int, Kernel, CGAL::Constrained_triangulation_face_base_2<Kernel>>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;

// Nesting level of every face: 0 outside the outline, 1 inside, 2 in a hole, ... (breadth first
// over unconstrained edges, one level deeper across each constraint).
void mark_nesting(Cdt& cdt) {
  for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info() = -1;
  std::list<Cdt::Edge> border;
  auto flood = [&](Cdt::Face_handle start, int level) {
    if (start->info() != -1) return;
    std::vector<Cdt::Face_handle> queue{start};
    start->info() = level;
    while (!queue.empty()) {
      const Cdt::Face_handle f = queue.back();
      queue.pop_back();
      for (int i = 0; i < 3; ++i) {
        const Cdt::Face_handle n = f->neighbor(i);
        if (n->info() != -1) continue;
        if (cdt.is_constrained(Cdt::Edge(f, i))) {
          border.emplace_back(f, i);
        } else {
          n->info() = level;
          queue.push_back(n);
        }
      }
    }
  };
  flood(cdt.infinite_face(), 0);
  while (!border.empty()) {
    const Cdt::Edge e = border.front();
    border.pop_front();
    const Cdt::Face_handle n = e.first->neighbor(e.second);
    if (n->info() == -1) flood(n, e.first->info() + 1);
  }
}

// The paper's search pass: one mark per vertex. The paper's "set of unique search hits" is the
// loop itself: each vertex is decided once, against the unmodified mesh, so the order of the
// visit does not matter. With `border_out`, also every border edge a->n, read off the same rings.
std::vector<VertexMark> search(const Mesh& mesh, const Corners& corners, const PaperSimplifyOptions& options,
                               std::vector<std::pair<uint32_t, uint32_t>>* border_out) {
  check_paper_options(options);
  const Marker marker(mesh, options);
  std::vector<VertexMark> marks(mesh.vertices.size(), VertexMark::Kept);
  Ring ring;
  for (uint32_t a = 0; a < mesh.vertices.size(); ++a) {
    if (corners.begin[a] == corners.begin[a + 1]) continue;  // no triangle, no neighbour
    ring.gather(corners, a);
    if (marker.coplanar(a, ring)) {
      marks[a] = VertexMark::Coplanar;
    } else if (marker.colinear(a, ring)) {
      marks[a] = VertexMark::Colinear;
    }
    if (border_out)
      for (uint32_t n : ring.border_next) border_out->emplace_back(a, n);
  }
  return marks;
}

}  // namespace

void check_paper_options(const PaperSimplifyOptions& options) {
  if (!(options.dz >= 0 && options.dz <= 1000))
    throw ArgumentError("dz", "must be from 0 to 1000, got " + short_number(options.dz));
  if (!(options.dco >= 0 && options.dco <= 1000))
    throw ArgumentError("dco", "must be from 0 to 1000, got " + short_number(options.dco));
}

const char* to_string(PaperVariant variant) { return variant == PaperVariant::One ? "variant1" : "variant2"; }

std::vector<VertexMark> mark_paper(const Mesh& mesh, const PaperSimplifyOptions& options) {
  return search(mesh, Corners(mesh), options, nullptr);
}

PaperSimplifyResult simplify_paper(const Mesh& mesh, const PaperSimplifyOptions& options, const Progress& progress) {
  PaperSimplifyResult result;
  Stopwatch clock;
  const Corners corners(mesh);
  std::vector<std::pair<uint32_t, uint32_t>> border_out;
  const std::vector<VertexMark> marks = search(mesh, corners, options, &border_out);
  result.seconds_search = clock.lap();
  report(progress, 0.2);

  // Border edges of the input, chained past removed (co-linear) border vertices.
  std::vector<uint32_t> border_next(mesh.vertices.size(), none);
  std::vector<std::pair<uint32_t, uint32_t>> border_edges;
  for (const auto& [a, n] : border_out) {
    if (marks[a] == VertexMark::Kept)
      border_edges.emplace_back(a, n);
    else
      border_next[a] = n;  // removed border vertices have exactly one border successor
  }
  report(progress, 0.3);

  // The CDT's vertices carry their input index.
  std::vector<std::pair<Kernel::Point_2, uint32_t>> points;
  for (uint32_t v = 0; v < mesh.vertices.size(); ++v)
    if (marks[v] == VertexMark::Kept) points.emplace_back(Kernel::Point_2(mesh.vertices[v].x, mesh.vertices[v].y), v);
  Cdt cdt;
  cdt.insert(points.begin(), points.end());
  report(progress, 0.6);
  std::vector<Cdt::Vertex_handle> handle(mesh.vertices.size());
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) handle[v->info()] = v;
  for (auto [a, n] : border_edges) {
    size_t steps = 0;
    while (marks[n] != VertexMark::Kept && steps++ < mesh.vertices.size()) n = border_next[n];
    if (marks[n] != VertexMark::Kept) continue;  // a border loop without a survivor (corners stay)
    cdt.insert_constraint(handle[a], handle[n]);
  }

  // A co-linear vertex goes because it lies "on an edge between two neighbour vertices" (the
  // paper's Fig. 5); Delaunay need not keep that edge, and where it does not, the surface over
  // the vertex drops off its line (a wall top cut down to the street). Such vertices are put
  // back, until the surface over every removed co-linear vertex is within dz of it (and covers it).
  // Each is looked up from a kept vertex near it (vertex handles outlive insertions; faces do not).
  std::vector<std::pair<uint32_t, Cdt::Vertex_handle>> colinear;
  Cdt::Vertex_handle near = points.empty() ? Cdt::Vertex_handle() : handle[points.front().second];
  Ring ring;
  for (uint32_t v = 0; v < mesh.vertices.size(); ++v) {
    if (marks[v] != VertexMark::Colinear) continue;
    ring.gather(corners, v);
    for (uint32_t n : ring.neighbours)
      if (marks[n] == VertexMark::Kept) near = handle[n];
    colinear.emplace_back(v, near);
  }
  std::vector<bool> restored(mesh.vertices.size(), false);
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<uint32_t> off_line;
    for (const auto& [v, hint] : colinear) {
      if (restored[v]) continue;
      const Vertex& p = mesh.vertices[v];
      // No surface over it at all misses it too: survivors on one line or none (every vertex
      // marked, the hint then null: fuzz_pipeline), or the vertex outside their hull.
      if (cdt.dimension() < 2) {
        off_line.push_back(v);
        continue;
      }
      Cdt::Locate_type type;
      int li;
      Cdt::Face_handle f = cdt.locate(Kernel::Point_2(p.x, p.y), type, li, hint->face());
      if (cdt.is_infinite(f) && type == Cdt::EDGE) f = f->neighbor(li);
      if (cdt.is_infinite(f)) {
        off_line.push_back(v);
        continue;
      }
      const Vertex &a = mesh.vertices[f->vertex(0)->info()], &b = mesh.vertices[f->vertex(1)->info()],
                   &c = mesh.vertices[f->vertex(2)->info()];
      const double area = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
      const double wb = ((p.x - a.x) * (c.y - a.y) - (c.x - a.x) * (p.y - a.y)) / area;
      const double wc = ((b.x - a.x) * (p.y - a.y) - (p.x - a.x) * (b.y - a.y)) / area;
      const double z = a.z + wb * (b.z - a.z) + wc * (c.z - a.z);
      if (std::abs(z - p.z) > options.dz + height_slack) off_line.push_back(v);
    }
    for (uint32_t v : off_line) {
      restored[v] = true;
      cdt.insert(Kernel::Point_2(mesh.vertices[v].x, mesh.vertices[v].y))->info() = v;
      changed = true;
    }
  }
  report(progress, 0.9);

  // Survivors (and restored vertices) keep their input order.
  std::vector<uint32_t> new_index(mesh.vertices.size(), none);
  result.mesh.crs = mesh.crs;
  for (uint32_t v = 0; v < mesh.vertices.size(); ++v) {
    if (marks[v] == VertexMark::Coplanar) {
      ++result.removed_coplanar;
    } else if (marks[v] == VertexMark::Colinear && !restored[v]) {
      ++result.removed_colinear;
    } else {
      result.restored_colinear += restored[v];
      new_index[v] = static_cast<uint32_t>(result.mesh.vertices.size());
      result.mesh.vertices.push_back(mesh.vertices[v]);
    }
  }
  mark_nesting(cdt);
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (f->info() % 2 == 1) {
      result.mesh.triangles.push_back(
          {new_index[f->vertex(0)->info()], new_index[f->vertex(1)->info()], new_index[f->vertex(2)->info()]});
    }
  }
  result.seconds_triangulate = clock.lap();
  report(progress, 1);
  return result;
}

void check_2_5d(const Mesh& mesh, const std::string& file) {
  const size_t n = mesh.vertices.size();
  std::vector<uint64_t> directed;
  directed.reserve(3 * mesh.triangles.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Triangle& tri = mesh.triangles[t];
    const std::string place = "triangle " + std::to_string(t);
    for (uint32_t v : tri)
      if (v >= n) throw InputError(file, place, "vertex index " + std::to_string(v) + " out of range");
    const Vertex &a = mesh.vertices[tri[0]], &b = mesh.vertices[tri[1]], &c = mesh.vertices[tri[2]];
    const double cross = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    if (!(cross > 0)) {
      throw InputError(file, place,
                       cross < 0 ? "is clockwise seen from above: the mesh is not 2.5D (it folds over)"
                                 : "has no area seen from above (vertical or degenerate): the mesh is not 2.5D");
    }
    for (int k = 0; k < 3; ++k) directed.push_back(uint64_t(tri[k]) << 32 | tri[(k + 1) % 3]);
  }
  std::sort(directed.begin(), directed.end());
  const auto repeated = std::adjacent_find(directed.begin(), directed.end());
  if (repeated != directed.end()) {
    throw InputError(file, "edge " + std::to_string(*repeated >> 32) + "-" + std::to_string(*repeated & 0xffffffffu),
                     "shared by two triangles on the same side: the mesh is not 2.5D (it folds over)");
  }
  std::vector<uint32_t> order(n);
  for (uint32_t v = 0; v < n; ++v) order[v] = v;
  auto xy_less = [&](uint32_t p, uint32_t q) {
    return std::pair(mesh.vertices[p].x, mesh.vertices[p].y) < std::pair(mesh.vertices[q].x, mesh.vertices[q].y);
  };
  std::sort(order.begin(), order.end(), xy_less);
  for (size_t i = 1; i < n; ++i) {
    const Vertex &p = mesh.vertices[order[i - 1]], &q = mesh.vertices[order[i]];
    if (p.x == q.x && p.y == q.y) {
      throw InputError(file, "vertices " + std::to_string(order[i - 1]) + " and " + std::to_string(order[i]),
                       "share x,y: the mesh is not 2.5D (one height per position)");
    }
  }
}

}  // namespace dsmplan
