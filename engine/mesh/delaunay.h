#pragma once
// Delaunay tetrahedralization on every core: Bowyer-Watson insertion in rounds with deterministic reservations
// (Blelloch et al. 2012, "Internally deterministic parallel algorithms can be fast"). TetGen's Delaunay runs on one
// thread; at the paper's head size (1.7 M particles) it was 14 s of the 43 s surface stage on a 16-core H200 host.
//
// The points go in levels of a seeded random order (BRIO), each level along a Morton curve cut into lanes; a round
// takes the next point of every lane, with the points put off before first. Every point of the round finds, on the
// tetrahedralization as the round found it, the tet holding it (a visibility walk from the tet its lane predecessor
// made, else from its grid cell's last) and its cavity (the tets whose open circumball holds it, grown across
// faces); it then reserves its cavity and the tets just outside it (an atomic minimum of its place in the round). A
// point that holds every reservation it made replaces its cavity by the tets joining the point to the cavity's
// boundary; the others wait for the next round. Reserved sets of points that commit together are disjoint, so their
// insertions do not interact; new slots and hints are handed out in round order, so every output array depends on
// the input alone, never on the threads.
//
// The hull is closed by tets with an infinite vertex (as in CGAL): a point beyond a hull face conflicts with its
// infinite tet, and one in the face's plane when it lies strictly inside the face's circumcircle. With strict
// conflicts every boundary face of a cavity is strictly visible from its point, so the new finite tets are never
// flat, even for cospherical points (a lattice): the result is then one of the Delaunay tetrahedralizations.
// Exact predicates (TetGen's, Shewchuk's, with static filters for the points' bounding box) throughout, on the points
// scaled by a power of two to coordinates under 2 (exact; far from 1 their products overflow or underflow).
//
// After the build, and after each later insertion of points, every face is checked: finite tets positively
// oriented, neighbours sharing the face, each inner face locally Delaunay (the apex across it not strictly inside
// the tet's circumsphere), the hull locally convex. Should a build's check fail (or an insertion meet a degenerate
// hull: a point on the line of a hull edge, which exact predicates should never let happen), the points are meshed
// by TetGen's delaunay() in a child process instead (it crashes on some degenerate sets) and DelaunayStats::fell_back
// says why; should a later insertion's, all points are built afresh.
#include <memory>
#include <string>
#include <vector>

#include "mesh/adjacency.h"
#include "mesh/tetgen.h"

namespace cpmesh::mesh {

struct DelaunayStats {
  size_t rounds = 0;         // batches
  size_t retries = 0;        // insertions put off to a later round (lost a reservation)
  size_t duplicates = 0;     // points at exactly the place of an earlier one (not meshed)
  size_t rebuilds = 0;       // DelaunayMesh::insert calls that meshed all points afresh
  bool fell_back = false;    // meshed by TetGen instead
  std::string why;           // why it fell back
};

// A Delaunay tetrahedralization that more points can be inserted into (the repair of extract.h adds a few points on
// triple curves to a mesh of millions; the same rounds insert them). Throws std::runtime_error with fewer than 4
// points, a coordinate that is not finite, all points on one plane, too many points (150 M: faces are named in 32
// bits), or points too close together for the predicates (a spread under 2^-200 of their largest coordinate).
// Uses the TBB threads the caller allows (tbb::global_control); instances may be built and used on several threads at
// once (the predicates' filters are each instance's own: FilteredPredicates in tetgen.h).
class DelaunayMesh {
 public:
  explicit DelaunayMesh(const std::vector<glm::dvec3>& points);
  ~DelaunayMesh();
  DelaunayMesh(DelaunayMesh&&) noexcept;
  DelaunayMesh& operator=(DelaunayMesh&&) noexcept;

  // Adds points after those given so far (they are numbered on from there), each into the mesh as it stands, by the
  // same rounds as the build: a point beyond the hull grows it, an exact duplicate of a point given before is in no
  // tet. All points are meshed afresh instead (stats().rebuilds) where TetGen made the mesh, where a new coordinate
  // is 2 or more times the largest the build saw, or where an insertion or the check after it fails. Throws (and
  // adds nothing) where a new coordinate is not finite.
  void insert(const std::vector<glm::dvec3>& points);
  // The tetrahedralization of every point given, as delaunay() (tetgen.h) gives it: points = the input, tets over
  // input indices, neighbours filled (4 per tet, the one across the face opposite each corner, -1 on the hull), every
  // tet oriented as TetGen's are (orient3d_exact < 0). The tets are the same in general position (the
  // tetrahedralization is unique), listed in another order. Where adjacency is given, the tets' face adjacency too
  // (as build_adjacency finds it, without its search). Throws std::logic_error where insert's rebuild threw.
  Tets tets(Adjacency* adjacency = nullptr) const;
  const DelaunayStats& stats() const;  // summed over the build and the insertions

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// DelaunayMesh(points).tets(), its stats in *stats.
Tets parallel_delaunay(const std::vector<glm::dvec3>& points, DelaunayStats* stats = nullptr);

}  // namespace cpmesh::mesh
