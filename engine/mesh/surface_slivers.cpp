#include "mesh/surface_slivers.h"

#include <algorithm>
#include <cmath>

#include "mesh/elements_around.h"
#include "mesh/quality.h"
#include "mesh/smooth.h"

namespace cpmesh::mesh {
namespace {

using Tet = std::array<uint32_t, 4>;
using Triangle = std::array<uint32_t, 3>;

constexpr uint8_t kInterface = 1, kPoint = 3;  // `movable`'s kinds (2: a triple-curve vertex)

enum class Star { closed, open, broken };

// Closed: every face through v is shared by exactly two of v's tets, so v's tets tile a ball around it. Open: v is on
// the outer boundary of the meshed materials (the outside is not meshed), every face through v with one tet being
// one of v's interface triangles; a move must then be checked against the triangles across the outside
// (undo_crossings). Broken: anything else (tets missing where a run left a part out).
Star star_of(uint32_t v, std::span<const uint32_t> mine, std::span<const uint32_t> faces, const std::vector<Tet>& tets,
             const std::vector<Triangle>& triangles) {
  using Edge = std::array<uint32_t, 2>;  // the face (v, a, b) as (a, b), a < b
  auto edge_of = [v](std::span<const uint32_t> corners) {
    Edge e{};
    size_t n = 0;
    for (uint32_t u : corners)
      if (u != v && n < 2) e[n++] = u;
    return std::array<uint32_t, 2>{std::min(e[0], e[1]), std::max(e[0], e[1])};
  };
  std::vector<Edge> edges;
  for (uint32_t t : mine)
    for (int skip = 0; skip < 4; ++skip)
      if (tets[t][size_t(skip)] != v) edges.push_back(edge_of(face_opposite(tets[t], skip)));
  std::vector<Edge> on_interface;
  for (uint32_t f : faces) on_interface.push_back(edge_of(triangles[f]));
  std::sort(edges.begin(), edges.end());
  std::sort(on_interface.begin(), on_interface.end());
  Star star = Star::closed;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i > 2) return Star::broken;
    if (j - i == 1) {
      if (!std::binary_search(on_interface.begin(), on_interface.end(), edges[i])) return Star::broken;
      star = Star::open;
    }
    i = j;
  }
  return star;
}

// How good vertex v's neighbourhood is at its current position: how many of its tets are under the bound, the
// smallest dihedral angle among them and the smallest radius ratio among its interface triangles. Fewer tets under
// the bound come first, then (while any is left) a larger smallest angle, then a larger smallest ratio. `valid` is
// false where a tet turned over (against `sign`) or went over `radius_edge`, or an interface triangle of v fell
// under `min_ratio` or turned more than 30 degrees from `normals`.
struct Score {
  bool valid = false;
  size_t below = 0;
  double worst = 0, shape = 0;
  bool better_than(const Score& o) const {
    if (!valid) return false;
    if (!o.valid || below != o.below) return !o.valid || below < o.below;
    return below > 0 ? worst > o.worst : shape > o.shape;
  }
};

class Mover {
 public:
  Mover(std::vector<glm::dvec3>& P, const std::vector<Tet>& tets, const std::vector<Triangle>& triangles,
        const FeatureProjection& project, double target, const SurfaceMoveOptions& options)
      : P_(P), tets_(tets), triangles_(triangles), project_(project), target_(target),
        max_radius_edge_(options.max_radius_edge), max_offset_(options.max_offset), min_shape_(options.min_ratio),
        tets_around_(P.size(), tets),
        triangles_around_(P.size(), triangles), anchor_(P) {}

  double min_angle(uint32_t t) const { return min_dihedral(P_, tets_[t]); }
  std::span<const uint32_t> tets_around(uint32_t v) const { return tets_around_[v]; }

  // Tries to move v (its kind as `movable` says: kInterface, 2 for a curve vertex, or kPoint); true if it moved.
  // `open`: whether v's star is open (star_of).
  bool move(uint32_t v, uint8_t kind, int pass, bool& open) {
    const auto mine = tets_around_[v];
    const auto faces = triangles_around_[v];
    if (mine.empty() || faces.empty()) return false;
    const Star star = star_of(v, mine, faces, tets_, triangles_);
    if (star == Star::broken || !prepare(v)) return false;
    open = star == Star::open;
    const glm::dvec3 start = P_[v];
    best_ = score(v);
    best_at_ = start;
    if (kind != kPoint) search(v, kind, pass, 0);
    if (wanting(best_) && max_offset_ > 0) search(v, kind, pass, max_offset_);
    P_[v] = best_at_;
    return best_at_ != start;
  }

 private:
  // The bounds v's move must hold (the orientations of its tets, the radius-edge limit, its triangles' worst radius
  // ratio and normals) and its star's mean edge length at v and mean normal; false where the normal vanishes.
  bool prepare(uint32_t v) {
    sign_.clear();
    limit_ = 1.5 * max_radius_edge_;
    for (uint32_t t : tets_around_[v]) {
      const Tet& k = tets_[t];
      sign_.push_back(signed_volume6(P_, k) > 0 ? 1 : -1);
      limit_ = std::max(limit_, radius_edge_ratio(P_[k[0]], P_[k[1]], P_[k[2]], P_[k[3]]));
    }
    normals_.clear();
    glm::dvec3 normal(0.0);
    double min_ratio = 1, edge = 0;
    const auto faces = triangles_around_[v];
    for (uint32_t f : faces) {
      const Triangle& tri = triangles_[f];
      normals_.push_back(glm::normalize(triangle_normal(P_, tri)));
      normal += triangle_normal(P_, tri);
      min_ratio = std::min(min_ratio, radius_ratio(P_[tri[0]], P_[tri[1]], P_[tri[2]]));
      for (uint32_t u : tri) edge += glm::length(P_[u] - P_[v]) / 2;  // each triangle's two edges at v
    }
    if (glm::length(normal) == 0) return false;
    normal_ = glm::normalize(normal);
    edge_ = edge / double(faces.size());
    min_ratio_ = std::min(min_ratio, 0.5);
    return true;
  }

  // Random steps around the best position so far (shrinking), each put back on v's feature; with `offset` > 0, each
  // then leaves the feature by up to `offset` or the step, if shorter (along the normal for an interface vertex, in any
  // direction for a curve vertex or a point, which has no steps of its own): where the material is thinner than its triangles are long, no
  // position on the feature mends the tets across it.
  void search(uint32_t v, uint8_t kind, int pass, double offset) {
    constexpr double kSteps[] = {0.5, 0.3, 0.2, 0.12, 0.06, 0.03};
    constexpr int kDraws = 12;
    uint64_t draw = offset > 0 ? kOffsetDraws : 0;
    for (double step : kSteps)
      for (int d = 0; d < kDraws && wanting(best_); ++d, ++draw) {  // until v's tets and triangles are over their bounds
        glm::dvec3 on = anchor_[v];
        if (kind != kPoint && !step_on_feature(v, kind, offset > 0, step, random_direction(v, pass, draw), on))
          continue;
        if (offset > 0) {
          const uint64_t other = draw + kOffsetDraws / 2;
          const glm::dvec3 away = kind == kInterface ? normal_ : random_direction(v, pass, other);
          const double share = std::clamp(hashed_normal(3 * key(v, pass, other + kOffsetDraws / 4)), -1.0, 1.0);
          on += share * std::min(offset, step * edge_) * away;  // shrinking with the steps, as tiny triangles need
        }
        P_[v] = on;
        const Score s = score(v);
        if (s.better_than(best_)) best_ = s, best_at_ = on;
      }
  }

  // A step of `step` mean edge lengths along `dir` (in the plane of v's triangles for an interface vertex) from the
  // best position so far (put back on v's feature first where `from_feature`, so that offsets do not add up over the
  // passes), put back on v's feature; false where the projection fails.
  bool step_on_feature(uint32_t v, uint8_t kind, bool from_feature, double step, const glm::dvec3& dir,
                       glm::dvec3& on) const {
    const glm::dvec3 along = kind == kInterface ? dir - glm::dot(dir, normal_) * normal_ : dir;
    if (glm::length(along) == 0) return false;
    glm::dvec3 from = best_at_;
    if (from_feature && !project_(v, best_at_, from)) from = best_at_;
    return project_(v, from + step * edge_ * glm::normalize(along), on);
  }

  static constexpr uint64_t kOffsetDraws = 1 << 10;  // the offset search's draws, apart from the first search's
  static uint64_t key(uint32_t v, int pass, uint64_t draw) {
    return (uint64_t(v) << 20) ^ (uint64_t(pass) << 12) ^ draw;
  }
  static glm::dvec3 random_direction(uint32_t v, int pass, uint64_t draw) {
    const uint64_t k = key(v, pass, draw);
    const glm::dvec3 d(hashed_normal(3 * k), hashed_normal(3 * k + 1), hashed_normal(3 * k + 2));
    return glm::length(d) > 0 ? glm::normalize(d) : d;
  }

  // Whether a position still leaves a tet of v under the dihedral bound or a triangle of v under the ratio bound.
  bool wanting(const Score& s) const { return s.below > 0 || s.shape < min_shape_; }

  Score score(uint32_t v) const {
    Score s;
    const auto mine = tets_around_[v];
    s.worst = M_PI;
    for (size_t i = 0; i < mine.size(); ++i) {
      const Tet& k = tets_[mine[i]];
      if (signed_volume6(P_, k) * sign_[i] <= 0) return s;
      if (radius_edge_above(P_[k[0]], P_[k[1]], P_[k[2]], P_[k[3]], limit_)) return s;
      const double a = min_dihedral(P_, k);
      s.below += a < target_;
      s.worst = std::min(s.worst, a);
    }
    const auto faces = triangles_around_[v];
    s.shape = 1;
    for (size_t i = 0; i < faces.size(); ++i) {
      const Triangle& tri = triangles_[faces[i]];
      const double ratio = radius_ratio(P_[tri[0]], P_[tri[1]], P_[tri[2]]);
      if (ratio < min_ratio_) return s;
      s.shape = std::min(s.shape, ratio);
      const glm::dvec3 n = triangle_normal(P_, tri);
      if (glm::dot(n, normals_[i]) <= std::cos(M_PI / 6) * glm::length(n)) return s;
    }
    s.valid = true;
    return s;
  }

  std::vector<glm::dvec3>& P_;
  const std::vector<Tet>& tets_;
  const std::vector<Triangle>& triangles_;
  const FeatureProjection& project_;
  const double target_, max_radius_edge_, max_offset_, min_shape_;
  const ElementsAround<4> tets_around_;
  const ElementsAround<3> triangles_around_;
  const std::vector<glm::dvec3> anchor_;  // the positions before the passes: where a kPoint vertex belongs
  std::vector<int8_t> sign_;
  std::vector<glm::dvec3> normals_;
  glm::dvec3 normal_{0.0};
  double limit_ = 0, min_ratio_ = 0, edge_ = 0;
  Score best_;
  glm::dvec3 best_at_{0.0};
};

// Undoes moves of vertices with open stars (star_of) until no interface triangle with a moved vertex crosses another
// and no tet around an undone vertex has turned over against `start` (where a neighbour moved after it): the
// positions before every move are valid, so this ends. Returns how many moves it undid.
size_t undo_crossings(std::vector<glm::dvec3>& P, const std::vector<glm::dvec3>& start, const std::vector<Tet>& tets,
                      const std::vector<Triangle>& triangles, const std::vector<uint8_t>& moved_open) {
  std::vector<uint8_t> check(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t)
    for (uint32_t v : triangles[t]) check[t] |= moved_open[v];
  if (std::find(check.begin(), check.end(), 1) == check.end()) return 0;
  const ElementsAround<4> tets_around(P.size(), tets);
  size_t undone = 0;
  auto undo = [&](uint32_t v) {
    if (P[v] == start[v]) return false;
    P[v] = start[v];
    ++undone;
    return true;
  };
  std::vector<uint32_t> queue;
  for (const auto& pair : crossing_triangles(P, triangles, &check))
    for (uint32_t t : pair)
      for (uint32_t v : triangles[t])
        if (undo(v)) queue.push_back(v);
  while (!queue.empty()) {
    const uint32_t v = queue.back();
    queue.pop_back();
    for (uint32_t k : tets_around[v])
      if (signed_volume6(P, tets[k]) * signed_volume6(start, tets[k]) <= 0)
        for (uint32_t u : tets[k])
          if (undo(u)) queue.push_back(u);
  }
  return undone;
}

}  // namespace

SurfaceSliverReport move_surface_vertices(std::vector<glm::dvec3>& points, const std::vector<Tet>& tets,
                                          const std::vector<Triangle>& triangles, const std::vector<uint8_t>& movable,
                                          const FeatureProjection& project, const SurfaceMoveOptions& options) {
  SurfaceSliverReport report;
  const double target = options.target_deg * M_PI / 180;
  auto is_movable = [&](uint32_t v) { return v < movable.size() && movable[v]; };
  auto ratio = [&](const Triangle& t) { return radius_ratio(points[t[0]], points[t[1]], points[t[2]]); };
  auto slivers = [&] {
    std::vector<uint32_t> bad;
    for (uint32_t t = 0; t < tets.size(); ++t)
      if (std::any_of(tets[t].begin(), tets[t].end(), is_movable) && min_dihedral(points, tets[t]) < target)
        bad.push_back(t);
    return bad;
  };
  auto flats = [&] {
    std::vector<uint32_t> flat;
    for (uint32_t f = 0; f < triangles.size(); ++f)
      if (std::any_of(triangles[f].begin(), triangles[f].end(), is_movable) && ratio(triangles[f]) < options.min_ratio)
        flat.push_back(f);
    return flat;
  };
  std::vector<uint32_t> bad = slivers(), flat = flats();
  report.slivers_before = report.slivers_after = bad.size();
  report.flat_before = report.flat_after = flat.size();
  if (bad.empty() && flat.empty()) return report;
  const std::vector<glm::dvec3> start = points;
  std::vector<uint8_t> moved_open(points.size(), 0);
  Mover mover(points, tets, triangles, project, target, options);
  // A vertex is tried again only once something in its star has moved since it last failed.
  std::vector<uint8_t> stale(points.size(), 0);
  for (int pass = 0; pass < options.passes && !(bad.empty() && flat.empty()); ++pass) {
    size_t moved = 0;
    auto try_move = [&](uint32_t v) {
      bool open = false;
      if (!mover.move(v, movable[v], pass, open)) {
        stale[v] = 1;
        return;
      }
      moved_open[v] |= uint8_t(open);
      ++moved;
      for (uint32_t k : mover.tets_around(v))
        for (uint32_t u : tets[k]) stale[u] = 0;
    };
    for (uint32_t t : bad)
      for (uint32_t v : tets[t])
        if (is_movable(v) && !stale[v] && mover.min_angle(t) < target) try_move(v);
    for (uint32_t f : flat)
      for (uint32_t v : triangles[f])
        if (is_movable(v) && !stale[v] && ratio(triangles[f]) < options.min_ratio) try_move(v);
    report.moves += moved;
    bad = slivers();  // a move may leave a tet of its star under the bound where it lifts another
    flat = flats();
    if (moved == 0) break;
  }
  const size_t undone = undo_crossings(points, start, tets, triangles, moved_open);
  report.moves -= std::min(report.moves, undone);
  report.slivers_after = undone > 0 ? slivers().size() : bad.size();
  report.flat_after = undone > 0 ? flats().size() : flat.size();
  return report;
}

}  // namespace cpmesh::mesh
