#include "mesh/delaunay.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include "mesh/child_process.h"

namespace cpmesh::mesh {

namespace {

constexpr uint32_t kInf = ~0u;   // the infinite vertex
constexpr uint32_t kNone = ~0u;  // no reservation, no tet
constexpr uint32_t kUnused = kNone - 1;  // Tet::next of a slot handed to a lane and not yet used

uint32_t load(const uint32_t& x) { return std::atomic_ref<const uint32_t>(x).load(std::memory_order_relaxed); }
void store(uint32_t& x, uint32_t v) { std::atomic_ref<uint32_t>(x).store(v, std::memory_order_relaxed); }

// A small set of tet indices (a cavity: tens of tets, thousands for a point beyond a large hull).
class TetSet {
 public:
  void clear() {
    for (size_t i : filled_) slots_[i] = kNone;
    filled_.clear();
    used_ = 0;
  }
  // False if already there.
  bool insert(uint32_t t) {
    if ((used_ + 1) * 2 > slots_.size()) grow();
    size_t i = hash(t);
    while (slots_[i] != kNone) {
      if (slots_[i] == t) return false;
      i = (i + 1) & (slots_.size() - 1);
    }
    slots_[i] = t;
    filled_.push_back(i);
    ++used_;
    return true;
  }
  bool contains(uint32_t t) const {
    if (slots_.empty()) return false;
    for (size_t i = hash(t);; i = (i + 1) & (slots_.size() - 1)) {
      if (slots_[i] == t) return true;
      if (slots_[i] == kNone) return false;
    }
  }

 private:
  size_t hash(uint32_t t) const { return (size_t(t) * 0x9E3779B97F4A7C15ull >> 20) & (slots_.size() - 1); }
  void grow() {
    std::vector<uint32_t> old;
    old.swap(slots_);
    slots_.assign(std::max<size_t>(64, old.size() * 2), kNone);
    filled_.clear();
    used_ = 0;
    for (uint32_t t : old)
      if (t != kNone) insert(t);
  }
  std::vector<uint32_t> slots_;
  std::vector<size_t> filled_;  // where slots_ holds a tet (clear() resets only those)
  size_t used_ = 0;
};

struct Work {  // one point's insertion in a round
  uint32_t point = 0;
  uint32_t place = kNone;  // in its level's Morton order (kNone: put off from an earlier level)
  uint32_t hint = kNone;   // a tet to walk from (kNone: its grid cell's)
  std::vector<uint32_t> cavity;                       // tets whose open circumball holds the point
  std::vector<std::pair<uint32_t, uint32_t>> border;  // the cavity's boundary faces: (cavity tet, corner)
  std::vector<uint32_t> touched;                      // the cavity and the tets across its boundary
};

struct Scratch {  // per thread
  TetSet set;
  std::vector<uint64_t> edge_key;   // an open-addressing table of the new faces' edges on the cavity's boundary
  std::vector<uint32_t> edge_face;  // the first face (made index * 4 + corner) seen with it, or kNone once paired
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  std::vector<std::array<uint32_t, 4>> made;
  std::vector<uint32_t> slot, outside;
};

class Builder {
 public:
  explicit Builder(const std::vector<glm::dvec3>& points) : P_(points) {}

  const std::vector<glm::dvec3>& P_;
  FilteredPredicates pred;     // with the bounding box's static filters
  glm::dvec3 mid{0}, size{0};  // the points' bounding box (size as the predicates widened it)
  void set_box(const glm::dvec3& lo, const glm::dvec3& hi) {
    pred = FilteredPredicates(hi - lo);
    size = pred.extent();
    mid = lo + 0.5 * size;
  }
  struct Tet {                   // one record per tet: a cavity's tests touch one place in memory
    std::array<uint32_t, 4> v;    // corners; an infinite tet has kInf at one
    std::array<uint32_t, 4> n;    // (tet * 4 + corner) across the face opposite each corner
    uint32_t reserve = kNone;     // the lowest batch place that reserved it this round
    uint32_t next = kNone;        // kNone while alive; once dead, a tet made when it died (hints go on from there);
                                  // kUnused: a lane's slot not yet used
  };
  std::vector<Tet> T;
  uint32_t count = 0;  // tets made (alive or dead)
  uint32_t& across(uint32_t tc) { return T[tc / 4].n[tc % 4]; }
  bool alive(uint32_t t) const { return T[t].next == kNone; }
  std::atomic<bool> failed{false};
  std::string why;  // set once, by whoever set failed first (under the flag)

  static int inf_corner(const std::array<uint32_t, 4>& v) {
    for (int c = 0; c < 4; ++c)
      if (v[size_t(c)] == kInf) return c;
    return -1;
  }
  // orient3d of tet v with corner c at q (v's other corners finite).
  double orient_with(const std::array<uint32_t, 4>& v, int c, const glm::dvec3& q) const {
    const glm::dvec3* p[4];
    for (int k = 0; k < 4; ++k) p[k] = k == c ? &q : &P_[v[size_t(k)]];
    return pred.orient3d(*p[0], *p[1], *p[2], *p[3]);
  }
  double orient(const std::array<uint32_t, 4>& v) const {
    return pred.orient3d(P_[v[0]], P_[v[1]], P_[v[2]], P_[v[3]]);
  }
  // Finite tets are positively oriented; an infinite tet is positive with its infinite corner at any point strictly
  // beyond its finite face.
  bool conflict(uint32_t t, const glm::dvec3& q) const {
    const auto& v = T[t].v;
    const int k = inf_corner(v);
    if (k < 0) return pred.insphere(P_[v[0]], P_[v[1]], P_[v[2]], P_[v[3]], q) > 0;
    const double o = orient_with(v, k, q);
    if (o != 0) return o > 0;
    // In the hull face's plane: inside its circumcircle exactly when inside the finite neighbour's circumsphere.
    const auto& w = T[T[t].n[size_t(k)] / 4].v;
    return pred.insphere(P_[w[0]], P_[w[1]], P_[w[2]], P_[w[3]], q) > 0;
  }
  // Three points are collinear exactly when every point is coplanar with them. Probes off a along each axis,
  // towards the box's middle by half its size (floating-point values, so exactly the points tested, and within the
  // differences the exact predicates were set up for) cannot all lie in one plane through a.
  bool collinear(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) const {
    for (int axis = 0; axis < 3; ++axis) {
      glm::dvec3 probe = a;
      probe[axis] += a[axis] > mid[axis] ? -0.5 * size[axis] : 0.5 * size[axis];
      if (pred.orient3d(a, b, c, probe) != 0) return false;
    }
    return true;
  }
  void fail(const std::string& reason) {
    bool expected = false;
    if (failed.compare_exchange_strong(expected, true)) why = reason;
  }

  // A live tet at or after hint: dead tets point at a tet made when they died.
  uint32_t live(uint32_t t) {
    uint32_t u = t;
    for (uint32_t n; (n = load(T[u].next)) != kNone;) u = n;
    return u;
  }

  // The tet holding q (a visibility walk), or the infinite tet across the hull face q lies beyond. kNone: the walk
  // did not end (never on a Delaunay tetrahedralization).
  uint32_t locate(const glm::dvec3& q, uint32_t hint) {
    uint32_t t = live(hint);
    if (const int k = inf_corner(T[t].v); k >= 0) t = T[t].n[size_t(k)] / 4;
    const size_t limit = 4 * size_t(count) + 64;
    for (size_t step = 0; step < limit; ++step) {
      const auto& v = T[t].v;
      bool moved = false;
      for (int i = 0; i < 4 && !moved; ++i) {
        const int c = int((step + size_t(i)) % 4);  // rotating start: no cycling on ties
        if (orient_with(v, c, q) >= 0) continue;
        const uint32_t n = T[t].n[size_t(c)] / 4;
        if (inf_corner(T[n].v) >= 0) return n;
        t = n;
        moved = true;
      }
      if (!moved) return t;
    }
    return kNone;
  }

  void find_cavity(Work& w, uint32_t start, TetSet& set) {
    const glm::dvec3& q = P_[w.point];
    w.cavity.assign(1, start);
    w.border.clear();
    set.clear();
    set.insert(start);
    for (size_t i = 0; i < w.cavity.size(); ++i) {
      const uint32_t u = w.cavity[i];
      for (uint32_t c = 0; c < 4; ++c) {
        const uint32_t n = T[u].n[c] / 4;
        if (set.contains(n)) continue;
        if (conflict(n, q)) {
          set.insert(n);
          w.cavity.push_back(n);
        } else {
          w.border.push_back({u, c});
        }
      }
    }
    w.touched = w.cavity;
    for (const auto& [u, c] : w.border) w.touched.push_back(T[u].n[c] / 4);
  }

  // Whether every corner of w's cavity lies on its boundary (else the insertion would drop a point).
  bool keeps_corners(const Work& w) const {
    for (uint32_t u : w.cavity)
      for (uint32_t x : T[u].v) {
        bool on = x == kInf;
        for (size_t k = 0; k < w.border.size() && !on; ++k) {
          const auto& [t, c] = w.border[k];
          on = x != T[t].v[c] && std::find(T[t].v.begin(), T[t].v.end(), x) != T[t].v.end();
        }
        if (!on) return false;
      }
    return true;
  }

  // Replaces w's cavity by the tets joining its point to the cavity's boundary. Only w's reserved tets are read or
  // written; the tets beyond the cavity's count go to slots base, base + 1, ... (unused or fresh ones)
  void commit(const Work& w, uint32_t base, Scratch& s) {
    const uint32_t qi = w.point;
    s.made.clear();
    for (const auto& [u, c] : w.border) {
      auto v = T[u].v;
      v[c] = qi;
      // A new finite tet is never flat (strict conflicts; check() verifies it), a new hull face can be.
      if (const int k = inf_corner(v); k >= 0) {
        glm::dvec3 f[3];
        for (int j = 0, m = 0; j < 4; ++j)
          if (j != k) f[m++] = P_[v[size_t(j)]];
        if (collinear(f[0], f[1], f[2])) {
          fail("a point on the line of a hull edge");
          return;
        }
      }
      s.made.push_back(v);
    }
    // The faces through q pair up by their edge on the cavity's boundary (a closed surface: every edge twice).
    constexpr uint64_t kEmpty = ~0ull;
    const size_t edges = 3 * s.made.size();
    size_t size = 64;
    while (size < 2 * edges) size *= 2;
    s.edge_key.assign(size, kEmpty);
    s.edge_face.resize(size);
    s.pairs.clear();
    bool closed = true;
    for (size_t k = 0; k < s.made.size() && closed; ++k) {
      const uint32_t c = w.border[k].second;
      for (uint32_t j = 0; j < 4; ++j) {
        if (j == c) continue;
        uint32_t e[2], m = 0;
        for (uint32_t x = 0; x < 4; ++x)
          if (x != j && x != c) e[m++] = s.made[k][x];
        const uint64_t key = uint64_t(std::min(e[0], e[1])) << 32 | std::max(e[0], e[1]);
        size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> 40) & (size - 1);
        while (s.edge_key[h] != kEmpty && s.edge_key[h] != key) h = (h + 1) & (size - 1);
        if (s.edge_key[h] == kEmpty) {
          s.edge_key[h] = key;
          s.edge_face[h] = uint32_t(k * 4 + j);
        } else if (s.edge_face[h] == kNone) {
          closed = false;  // a third face on one edge
        } else {
          s.pairs.push_back({s.edge_face[h], uint32_t(k * 4 + j)});
          s.edge_face[h] = kNone;
        }
      }
    }
    if (!closed || 2 * s.pairs.size() != edges) {
      fail("a cavity whose boundary is not a closed surface");
      return;
    }
    const size_t nc = w.cavity.size(), nb = s.made.size();
    s.slot.resize(nb);
    s.outside.resize(nb);
    for (size_t k = 0; k < nb; ++k) {
      s.outside[k] = T[w.border[k].first].n[w.border[k].second];  // before any slot is overwritten
      s.slot[k] = k < nc ? w.cavity[k] : base + uint32_t(k - nc);
    }
    for (size_t k = 0; k < nb; ++k) {
      const uint32_t t = s.slot[k], c = w.border[k].second;
      T[t].v = s.made[k];
      T[t].next = kNone;  // (a slot from its lane's block was kUnused)
      T[t].n[c] = s.outside[k];
      across(s.outside[k]) = t * 4 + c;
    }
    for (const auto& [fa, fb] : s.pairs) {
      const uint32_t a = s.slot[fa / 4] * 4 + fa % 4, b = s.slot[fb / 4] * 4 + fb % 4;
      across(a) = b;
      across(b) = a;
    }
    for (size_t k = nb; k < nc; ++k) {  // a cavity can hold more tets than its boundary has faces
      store(T[w.cavity[k]].next, s.slot[0]);
    }
  }

  void grow(size_t tets) {
    if (T.size() >= tets) return;
    T.resize(std::max(tets, std::min(T.capacity(), T.size() + T.size() / 2)));  // within the reserve if it can
  }

  // The first tet and the four infinite ones around it.
  void start(std::array<uint32_t, 4> v) {
    if (orient(v) < 0) std::swap(v[0], v[1]);
    grow(64);
    T[0].v = v;
    for (uint32_t c = 0; c < 4; ++c) {
      auto w = v;
      w[c] = kInf;
      std::swap(w[(c + 1) % 4], w[(c + 2) % 4]);  // positive with kInf beyond the face
      T[1 + c].v = w;
    }
    count = 5;
    for (uint32_t a = 0; a < count; ++a)
      for (uint32_t ca = 0; ca < 4; ++ca)
        for (uint32_t b = 0; b < count; ++b)
          for (uint32_t cb = 0; cb < 4; ++cb) {
            if (a == b) continue;
            std::array<uint32_t, 3> fa, fb;
            for (uint32_t x = 0, i = 0, j = 0; x < 4; ++x) {
              if (x != ca) fa[i++] = T[a].v[x];
              if (x != cb) fb[j++] = T[b].v[x];
            }
            std::sort(fa.begin(), fa.end());
            std::sort(fb.begin(), fb.end());
            if (fa == fb) T[a].n[ca] = b * 4 + cb;
          }
  }

  // The checks of the header on the faces of live tet t; empty when all hold.
  // Each inner face's Delaunay test from both sides, or only from its tet of the higher index (a check of all tets).
  std::string check_tet(uint32_t t, bool both_sides) const {
    const auto& v = T[t].v;
    const int k = inf_corner(v);
    for (uint32_t c = 0; c < 4; ++c) {
      const uint32_t n = T[t].n[c];
      if (n == kNone || T[n / 4].n[n % 4] != t * 4 + c || !alive(n / 4)) return "an inconsistent adjacency";
      const auto& u = T[n / 4].v;
      const uint32_t apex = u[n % 4];
      for (uint32_t x = 0; x < 4; ++x)
        if (x != c && std::find(u.begin(), u.end(), v[x]) == u.end()) return "neighbours that share no face";
      if (k < 0) {
        if (c == 0 && !(orient(v) > 0)) return "a tet not positively oriented";
        if (apex != kInf && (both_sides || n / 4 > t) &&
            pred.insphere(P_[v[0]], P_[v[1]], P_[v[2]], P_[v[3]], P_[apex]) > 0)
          return "a face that is not locally Delaunay";
      } else if (c == uint32_t(k)) {
        if (apex == kInf || !(orient_with(v, k, P_[apex]) < 0)) return "a hull face that faces inwards";
      } else if (apex == kInf || inf_corner(u) < 0 || orient_with(v, k, P_[apex]) > 0) {
        return "a hull that is not convex";
      }
    }
    return {};
  }

  // Checks the faces of the live tets among `tets` (every tet made so far where null), and that every meshed point
  // from first_point on is a corner of one of them; empty when all hold. A point meshed before an insertion stays a
  // vertex (it lies on, never strictly inside, the circumspheres of its tets), and the tets an insertion did not make
  // keep their faces, so after one it is enough to check the tets it made from its first point on.
  std::string check(const std::vector<uint8_t>& meshed, const std::vector<uint32_t>* tets = nullptr,
                    size_t first_point = 0) const {
    const size_t n = tets ? tets->size() : count;
    auto tet_at = [&](size_t i) { return tets ? (*tets)[i] : uint32_t(i); };
    const std::string bad = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, n, 4096), std::string(),
        [&](const tbb::blocked_range<size_t>& r, std::string found) {
          for (size_t i = r.begin(); i < r.end() && found.empty(); ++i)
            if (alive(tet_at(i))) found = check_tet(tet_at(i), tets != nullptr);
          return found;
        },
        [](std::string a, const std::string& b) { return a.empty() ? b : a; });
    if (!bad.empty()) return bad;
    std::vector<uint8_t> seen(P_.size() - first_point, 0);
    for (size_t i = 0; i < n; ++i)
      if (alive(tet_at(i)))
        for (uint32_t x : T[tet_at(i)].v)
          if (x != kInf && x >= first_point) seen[x - first_point] = 1;
    for (size_t i = first_point; i < P_.size(); ++i)
      if (meshed[i] && !seen[i - first_point]) return "a point in no tet";
    return {};
  }
};


constexpr uint64_t kOrderSeed = 0x5eed;
constexpr size_t kShare = 256, kMaxLanes = 1024;  // the rounds' lanes (DelaunayMesh::Impl::run)
constexpr uint32_t kLaneBlock = 256;             // the slots a lane takes at a time

}  // namespace

struct DelaunayMesh::Impl {
  std::vector<glm::dvec3> input;   // every point given, as given
  std::vector<glm::dvec3> points;  // the same scaled by `scale` (what the predicates see)
  double scale = 1;
  glm::dvec3 lo{0}, hi{0};         // the scaled points' bounding box
  std::vector<uint8_t> meshed;     // 0: an exact duplicate of an earlier point
  std::vector<uint32_t> order;     // the meshed points in insertion order (the first four start the mesh)
  size_t cells_per_axis = 1;       // the grid of walk hints over the box the build saw
  glm::dvec3 grid_lo{0}, cell_size{1};
  std::vector<uint32_t> hint;      // per grid cell: a tet made there last
  std::unique_ptr<Builder> B;      // empty where TetGen meshed the points
  Tets tetgen;                     // TetGen's tets (fallback)
  DelaunayStats st;

  static void check_finite(const std::vector<glm::dvec3>& p) {
    for (const auto& x : p)
      if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
        throw std::runtime_error("Delaunay tetrahedralization: a point with a coordinate that is not finite");
  }
  // The predicates' static filters for the current box; where it is flat, widened (the collinearity probes go by the
  // widened size).
  void set_predicates() { B->set_box(lo, hi); }
  size_t cell_of(const glm::dvec3& p) const {
    size_t idx = 0;
    for (int a = 2; a >= 0; --a)
      idx = idx * cells_per_axis +
            size_t(std::clamp((p[a] - grid_lo[a]) / cell_size[a], 0.0, double(cells_per_axis - 1)));
    return idx;
  }

  void fall_back(const std::string& why) {
    st.fell_back = true;
    st.why = why;
    B.reset();
    const std::string bytes = run_in_child("Delaunay tetrahedralization (TetGen)", [&] {
      ByteWriter w;
      put_tets(w, delaunay(points));
      return w.take();
    });
    ByteReader r(bytes);
    if (!get_tets(r, tetgen) || !r.done()) throw std::runtime_error("TetGen: truncated result from the child process");
  }

  // Exact duplicates among points[first..]: all but the first of each (by index) get meshed = 0; returns how many.
  size_t mark_duplicates(size_t first) {
    std::vector<uint32_t> by_place(points.size() - first);
    std::iota(by_place.begin(), by_place.end(), uint32_t(first));
    tbb::parallel_sort(by_place.begin(), by_place.end(), [&](uint32_t a, uint32_t b) {
      const auto &p = points[a], &q = points[b];
      if (p.x != q.x) return p.x < q.x;
      if (p.y != q.y) return p.y < q.y;
      if (p.z != q.z) return p.z < q.z;
      return a < b;
    });
    size_t found = 0;
    for (size_t i = 1; i < by_place.size(); ++i)
      if (points[by_place[i]] == points[by_place[i - 1]]) {
        meshed[by_place[i]] = 0;
        ++found;
      }
    return found;
  }
  // Meshes `input` from scratch.
  void build();
  // Inserts order[begin..] into the mesh; where made is given, the tets it makes and the tets just outside their
  // cavities are appended to it, and every cavity must keep its corners. False where an insertion failed (B->why
  // says how).
  bool run(size_t begin, std::vector<uint32_t>* made = nullptr);
};

void DelaunayMesh::Impl::build() {
  B.reset();
  tetgen = {};
  st.fell_back = false;
  st.why.clear();
  if (input.size() < 4)
    throw std::runtime_error("Delaunay tetrahedralization needs at least 4 points, got " + std::to_string(input.size()));
  if (input.size() > (size_t(1) << 30) / 8)  // faces are named tet * 4 + corner in 32 bits, about 7 tets per point
    throw std::runtime_error("Delaunay tetrahedralization: too many points (" + std::to_string(input.size()) + ")");
  check_finite(input);
  // The predicates see the points scaled by a power of two (exact: no sign changes) to a largest coordinate in
  // [1, 2): far from 1, insphere's products overflow or underflow and every test says "not inside", a valid but not
  // Delaunay tetrahedralization that check() (the same predicates) would pass.
  double largest = 0;
  for (const auto& p : input) largest = std::max({largest, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  scale = largest > 0 ? std::ldexp(1.0, -std::ilogb(largest)) : 1.0;
  points.resize(input.size());
  tbb::parallel_for(size_t(0), input.size(), [&](size_t i) { points[i] = input[i] * scale; });
  const auto box_corners = bounding_box(points);
  lo = box_corners[0];
  hi = box_corners[1];
  // TetGen's exact predicates filter on the largest coordinate differences (the bounding box, as TetGen sets them
  // itself).
  const glm::dvec3 box = hi - lo;
  const double spread = std::max({box.x, box.y, box.z});
  if (spread < std::ldexp(1.0, -200)) {
    char why[160];
    std::snprintf(why, sizeof why, "spread %g at coordinates up to %g", spread / scale, largest);
    throw std::runtime_error(std::string("Delaunay tetrahedralization: the points are too close together for the "
                                         "exact predicates (") + why + ")");
  }
  B = std::make_unique<Builder>(points);
  set_predicates();

  // Exact duplicates: only the first is meshed.
  meshed.assign(points.size(), 1);
  st.duplicates = mark_duplicates(0);

  // A seeded random order; the first four points that span space start the mesh.
  order.clear();
  order.reserve(points.size());
  for (uint32_t i = 0; i < points.size(); ++i)
    if (meshed[i]) order.push_back(i);
  std::shuffle(order.begin(), order.end(), std::mt19937_64(kOrderSeed));
  // About 6.5 tets per point, a few dead, and the lanes' blocks' unused slots.
  B->T.reserve(size_t(7.0 * double(points.size())) + 64 +
               (std::min(points.size() / kShare, kMaxLanes) + 2) * size_t(kLaneBlock));
  std::array<uint32_t, 4> first;
  {
    size_t found = 0;
    auto take = [&](size_t i) {
      first[found++] = order[i];
      std::swap(order[i], order[found - 1]);
    };
    take(0);
    for (size_t i = found; i < order.size() && found < 4; ++i) {
      const glm::dvec3& p = points[order[i]];
      if (found == 1 ? p != points[first[0]]
          : found == 2 ? !B->collinear(points[first[0]], points[first[1]], p)
                       : B->pred.orient3d(points[first[0]], points[first[1]], points[first[2]], p) != 0)
        take(i);
    }
    if (found < 4)
      throw std::runtime_error("Delaunay tetrahedralization: all " + std::to_string(order.size()) +
                               " distinct points lie on one plane");
  }
  B->start(first);

  // A walk with no tet from its lane predecessor starts from the tet last made in its grid cell.
  cells_per_axis = std::clamp<size_t>(size_t(std::cbrt(double(order.size()) / 4.0)), 1, 256);
  grid_lo = lo;
  cell_size = glm::max(box, glm::dvec3(1e-300)) / double(cells_per_axis);
  hint.assign(cells_per_axis * cells_per_axis * cells_per_axis, 0);

  if (!run(4)) return fall_back(B->why);
  if (const std::string bad = B->check(meshed); !bad.empty()) return fall_back(bad);
}

bool DelaunayMesh::Impl::run(size_t first_level, std::vector<uint32_t>* made_tets) {
  // Levels of the random order (BRIO, Amenta et al. 2003): 1,024 points one at a time, then levels that double the
  // points meshed. A level's points are sorted along a Morton curve and cut into lanes, consecutive stretches of the
  // curve; a round takes the next point of every lane (with the ones put off before first). Each point walks from the
  // tet its predecessor in the lane made a round before, a few steps away, on the same thread (a static partition),
  // and the round's points are spread over the whole level, so their cavities rarely meet. Lanes: one per kShare
  // points meshed (more, and cavities meet so often that the put-off points pile up), at most kMaxLanes.
  // The tets a lane's points make beyond their cavities' slots come from the lane's own block of kLaneBlock slots
  // (lane k of every level: the same stretch of the curve), so that tets near each other in space lie near each
  // other in memory: the final check and the users of the tets miss the cache less (1.37 M surface points of the
  // paper-size head, two threads: the check 4.0 / 2.9 -> 2.5 / 2.3 s in two runs each, tets() on one thread 0.81 ->
  // 0.59 s; the whole build a few percent, within the machine's noise). The points put off from an earlier level
  // share one more block.
  auto morton = [&](uint32_t i) {
    uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const double x = (points[i][a] - lo[a]) / std::max(hi[a] - lo[a], 1e-300);
      const uint64_t v = uint64_t(std::clamp(x, 0.0, 1.0) * double((1u << 21) - 1));
      for (int b = 0; b < 21; ++b) code |= ((v >> b) & 1) << (3 * b + a);
    }
    return code;
  };
  Builder& b = *B;
  tbb::enumerable_thread_specific<Scratch> scratch;
  std::vector<Work> batch;
  std::vector<std::pair<uint32_t, uint32_t>> waiting;  // (point, place) that lost a reservation: first in later rounds
  std::vector<uint32_t> made_at;  // per place in the level: a tet its point made (kNone: not yet)
  std::vector<std::pair<uint64_t, uint32_t>> level;
  std::vector<uint32_t> queue;
  std::vector<uint8_t> won, duplicate;
  std::vector<uint32_t> base;  // the level's places in the order they are taken
  std::vector<uint32_t> lane_of;  // per place in the level: its lane
  std::vector<std::array<uint32_t, 2>> block(kMaxLanes + 1, {0, 0});  // per lane: its next free slot, its block's end
  std::vector<std::array<uint32_t, 2>> fresh;  // the blocks taken in a round
  size_t inserted = first_level;
  for (size_t begin = first_level; begin < order.size();) {
    const size_t end = std::min(order.size(), begin < 1024 ? 1024 : 2 * begin);
    level.resize(end - begin);
    tbb::parallel_for(begin, end, [&](size_t i) { level[i - begin] = {morton(order[i]), order[i]}; });
    tbb::parallel_sort(level.begin(), level.end());
    made_at.assign(level.size(), kNone);
    for (auto& w : waiting) w.second = kNone;  // its place was in the level before
    const size_t lanes = begin < 1024 ? 1 : std::clamp<size_t>(inserted / kShare, 1, kMaxLanes);
    queue.clear();
    lane_of.resize(level.size());
    for (size_t r = 0; r * lanes < level.size() + lanes; ++r)
      for (size_t lane = 0; lane < lanes; ++lane) {
        const size_t first_place = lane * level.size() / lanes, next_lane = (lane + 1) * level.size() / lanes;
        if (first_place + r < next_lane) {
          queue.push_back(uint32_t(first_place + r));
          lane_of[first_place + r] = uint32_t(lane);
        }
      }
    for (size_t taken = 0; taken < queue.size() || (end == order.size() && !waiting.empty());) {
      const size_t cap = lanes;
      const size_t from_waiting = std::min(cap, waiting.size());
      const size_t fresh_points = std::min(cap - from_waiting, queue.size() - taken);
      batch.resize(from_waiting + fresh_points);
      for (size_t j = 0; j < batch.size(); ++j) {
        Work& w = batch[j];
        if (j < from_waiting) {
          w.point = waiting[j].first;
          w.place = waiting[j].second;
          w.hint = w.place != kNone && w.place > 0 ? made_at[w.place - 1] : kNone;
        } else {
          const uint32_t k = queue[taken++];
          w.point = level[k].second;
          w.place = k;
          w.hint = k > 0 ? made_at[k - 1] : kNone;
        }
      }
      waiting.erase(waiting.begin(), waiting.begin() + ptrdiff_t(from_waiting));
      ++st.rounds;

      duplicate.assign(batch.size(), 0);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, batch.size(), 8), [&](const tbb::blocked_range<size_t>& r) {
        Scratch& s = scratch.local();
        for (size_t j = r.begin(); j < r.end(); ++j) {
          Work& w = batch[j];
          const glm::dvec3& q = points[w.point];
          const uint32_t t = b.locate(q, w.hint != kNone ? w.hint : hint[cell_of(q)]);
          if (t == kNone) {
            b.fail("a walk that did not end");
            continue;
          }
          // At a point already meshed (only an inserted point can be: the build drops duplicates first), the walk
          // ends in a tet with that point as a corner.
          const auto& v = b.T[t].v;
          if (Builder::inf_corner(v) < 0 &&
              (points[v[0]] == q || points[v[1]] == q || points[v[2]] == q || points[v[3]] == q)) {
            duplicate[j] = 1;
            w.touched.clear();
            continue;
          }
          b.find_cavity(w, t, s.set);
          // After an insertion only the tets it made are checked (insert), so here every corner of the cavity must
          // stay a corner, on its boundary (it always does on a Delaunay tetrahedralization).
          if (made_tets && !b.keeps_corners(w)) {
            b.fail("a cavity that holds a vertex");
            continue;
          }
          for (uint32_t u : w.touched) {
            std::atomic_ref<uint32_t> res(b.T[u].reserve);
            uint32_t cur = res.load(std::memory_order_relaxed);
            while (uint32_t(j) < cur && !res.compare_exchange_weak(cur, uint32_t(j), std::memory_order_relaxed)) {
            }
          }
        }
      }, tbb::static_partitioner());
      if (b.failed) return false;
      // The points holding all their reservations, and their new slots in batch order: with the hints set in that
      // order too, every array depends on the input alone, not on the threads.
      won.assign(batch.size(), 0);
      tbb::parallel_for(size_t(0), batch.size(), [&](size_t j) {
        bool mine = !duplicate[j];
        for (uint32_t u : batch[j].touched) mine = mine && load(b.T[u].reserve) == uint32_t(j);
        won[j] = mine;
      });
      base.resize(batch.size());
      uint32_t made = b.count;
      fresh.clear();
      for (size_t j = 0; j < batch.size(); ++j) {
        base[j] = made;
        if (!won[j] || batch[j].border.size() <= batch[j].cavity.size()) continue;
        const uint32_t extra = uint32_t(batch[j].border.size() - batch[j].cavity.size());
        auto& [next, end] = block[batch[j].place == kNone ? kMaxLanes : lane_of[batch[j].place]];
        if (end - next < extra) {  // the rest of the lane's block stays unused
          next = made;
          end = made = made + std::max(kLaneBlock, extra);
          fresh.push_back({next, end});
        }
        base[j] = next;
        next += extra;
      }
      b.grow(made);
      for (const auto& [first, end] : fresh)
        for (uint32_t t = first; t < end; ++t) b.T[t].next = kUnused;
      tbb::parallel_for(tbb::blocked_range<size_t>(0, batch.size(), 8), [&](const tbb::blocked_range<size_t>& r) {
        Scratch& s = scratch.local();
        for (size_t j = r.begin(); j < r.end(); ++j)
          if (won[j]) b.commit(batch[j], base[j], s);
      }, tbb::static_partitioner());
      if (b.failed) return false;
      b.count = made;
      for (size_t j = 0; j < batch.size(); ++j)
        if (won[j]) {
          const Work& w = batch[j];
          hint[cell_of(points[w.point])] = w.cavity[0];
          if (w.place != kNone) made_at[w.place] = w.cavity[0];
          if (made_tets) {
            for (size_t k = 0; k < w.border.size(); ++k)
              made_tets->push_back(k < w.cavity.size() ? w.cavity[k] : base[j] + uint32_t(k - w.cavity.size()));
            made_tets->insert(made_tets->end(), w.touched.begin() + ptrdiff_t(w.cavity.size()), w.touched.end());
          }
        }
      tbb::parallel_for(size_t(0), batch.size(), [&](size_t j) {
        for (uint32_t u : batch[j].touched) store(b.T[u].reserve, kNone);
      });
      for (size_t j = 0; j < batch.size(); ++j) {
        if (won[j]) {
          ++inserted;
        } else if (duplicate[j]) {
          meshed[batch[j].point] = 0;
          ++st.duplicates;
        } else {
          waiting.push_back({batch[j].point, batch[j].place});
          ++st.retries;
        }
      }
    }
    begin = end;
  }
  return true;
}

DelaunayMesh::DelaunayMesh(const std::vector<glm::dvec3>& points) : impl_(std::make_unique<Impl>()) {
  impl_->input = points;
  impl_->build();
}

DelaunayMesh::~DelaunayMesh() = default;
DelaunayMesh::DelaunayMesh(DelaunayMesh&&) noexcept = default;
DelaunayMesh& DelaunayMesh::operator=(DelaunayMesh&&) noexcept = default;

const DelaunayStats& DelaunayMesh::stats() const { return impl_->st; }

void DelaunayMesh::insert(const std::vector<glm::dvec3>& more) {
  Impl& m = *impl_;
  if (more.empty()) return;
  Impl::check_finite(more);
  if (m.input.size() + more.size() > (size_t(1) << 30) / 8)
    throw std::runtime_error("Delaunay tetrahedralization: too many points (" +
                             std::to_string(m.input.size() + more.size()) + ")");
  const size_t old = m.input.size();
  m.input.insert(m.input.end(), more.begin(), more.end());
  // Afresh where TetGen made the mesh, or where a new point would change the scale (a coordinate of 2 or more after
  // scaling).
  bool afresh = !m.B;
  for (const auto& p : more)
    afresh = afresh || std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}) * m.scale >= 2.0;
  if (afresh) {
    ++m.st.rebuilds;
    return m.build();
  }
  for (const auto& p : more) {
    m.points.push_back(p * m.scale);
    m.lo = glm::min(m.lo, m.points.back());
    m.hi = glm::max(m.hi, m.points.back());
  }
  m.set_predicates();  // the box may have grown
  // Exact duplicates among the new points: only the first goes in (the walk finds those of meshed points).
  m.meshed.resize(m.input.size(), 1);
  m.st.duplicates += m.mark_duplicates(old);
  const size_t begin = m.order.size();
  for (uint32_t i = uint32_t(old); i < m.input.size(); ++i)
    if (m.meshed[i]) m.order.push_back(i);
  std::shuffle(m.order.begin() + ptrdiff_t(begin), m.order.end(), std::mt19937_64(kOrderSeed + begin));
  std::vector<uint32_t> made;
  if (m.run(begin, &made)) {
    std::sort(made.begin(), made.end());
    made.erase(std::unique(made.begin(), made.end()), made.end());
    if (const std::string bad = m.B->check(m.meshed, &made, old); bad.empty()) return;
  }
  ++m.st.rebuilds;
  m.build();
}

Tets DelaunayMesh::tets(Adjacency* adjacency) const {
  const Impl& m = *impl_;
  if (!m.B && m.tetgen.tets.empty())  // a rebuild in insert() threw
    throw std::logic_error("DelaunayMesh: no tetrahedralization (the last insert failed)");
  if (!m.B) {
    Tets out = m.tetgen;
    out.points = m.input;
    if (adjacency) *adjacency = build_adjacency(out);
    return out;
  }
  const Builder& b = *m.B;
  // The finite tets, renumbered (in slot order), with TetGen's orientation (corners 0 and 1 swapped, and their
  // faces' neighbours); the hull's neighbours are -1.
  std::vector<uint32_t> index(b.count);
  tbb::parallel_for(uint32_t(0), b.count, [&](uint32_t t) {
    index[t] = b.alive(t) && Builder::inf_corner(b.T[t].v) < 0 ? 0 : kNone;
  });
  uint32_t finite = 0;
  for (uint32_t& i : index)
    if (i != kNone) i = finite++;
  Tets out;
  out.points = m.input;
  out.tets.resize(finite);
  out.neighbours.resize(size_t(finite) * 4);
  if (adjacency) adjacency->neighbour.resize(size_t(finite) * 4);
  auto corner = [](uint32_t c) { return c < 2 ? 1 - c : c; };
  tbb::parallel_for(uint32_t(0), b.count, [&](uint32_t t) {
    if (index[t] == kNone) return;
    const auto& v = b.T[t].v;
    out.tets[index[t]] = {v[1], v[0], v[2], v[3]};
    for (uint32_t c = 0; c < 4; ++c) {
      const uint32_t across = b.T[t].n[c], n = index[across / 4];
      const size_t face = size_t(index[t]) * 4 + corner(c);
      out.neighbours[face] = n == kNone ? -1 : int32_t(n);
      if (adjacency) adjacency->neighbour[face] = n == kNone ? Adjacency::kHull : n * 4 + corner(across % 4);
    }
  });
  return out;
}

Tets parallel_delaunay(const std::vector<glm::dvec3>& points, DelaunayStats* stats) {
  DelaunayMesh mesh(points);
  if (stats) *stats = mesh.stats();
  return mesh.tets();
}

}  // namespace cpmesh::mesh
