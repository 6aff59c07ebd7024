#include "mesh/tetgen.h"

#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>

#include <tetgen.h>

namespace cpmesh::mesh {

namespace {

void set_points(tetgenio& in, const std::vector<glm::dvec3>& points) {
  in.firstnumber = 0;
  in.numberofpoints = int(points.size());
  in.pointlist = new REAL[points.size() * 3];
  for (size_t i = 0; i < points.size(); ++i)
    for (int a = 0; a < 3; ++a) in.pointlist[3 * i + size_t(a)] = points[i][a];
}

Tets read_output(const tetgenio& out) {
  Tets t;
  for (int i = 0; i < out.numberofpoints; ++i)
    t.points.push_back({out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]});
  const int corners = out.numberofcorners;
  for (int i = 0; i < out.numberoftetrahedra; ++i) {
    std::array<uint32_t, 4> v;
    for (int a = 0; a < 4; ++a) v[size_t(a)] = uint32_t(out.tetrahedronlist[i * corners + a]);
    t.tets.push_back(v);
    if (out.numberoftetrahedronattributes > 0)
      t.region.push_back(int(out.tetrahedronattributelist[i * out.numberoftetrahedronattributes]));
  }
  for (int i = 0; i < out.numberoftrifaces; ++i) {
    t.faces.push_back({uint32_t(out.trifacelist[3 * i]), uint32_t(out.trifacelist[3 * i + 1]),
                       uint32_t(out.trifacelist[3 * i + 2])});
    t.face_marker.push_back(out.trifacemarkerlist ? out.trifacemarkerlist[i] : 0);
  }
  return t;
}

void run(const std::string& switches, tetgenio& in, tetgenio& out) {
  std::vector<char> sw(switches.begin(), switches.end());
  sw.push_back('\0');
  try {
    tetrahedralize(sw.data(), &in, &out);
  } catch (int code) {
    // TetGen's terminatetetgen codes: 1 out of memory, 2 internal error, 3 self-intersecting input, 4 a very small
    // input feature size, 5 a very close pair of input facets, 10 an input error.
    const char* why = code == 1   ? "out of memory"
                      : code == 3 ? "the input surfaces intersect each other"
                      : code == 4 || code == 5 ? "input features too small or facets too close for the tolerance"
                      : code == 10 ? "invalid input"
                                   : "internal error";
    throw std::runtime_error("TetGen (" + switches + ") failed with code " + std::to_string(code) + ": " + why);
  }
}

// TetGen 1.5 as Debian builds it frees its mesh when it gives up (terminatetetgen) and again while tetrahedralize
// unwinds, so a failure in boundary recovery (facets that intersect, say) is a double free that kills the process
// instead of an error it could report. Runs that can fail on their input therefore go to a forked child: it sends
// the output, or TetGen's error, back through a pipe; a child that dies makes a failed run with the signal named.
template <class T>
void put(std::string& buf, const std::vector<T>& v) {
  const uint64_t n = v.size();
  buf.append(reinterpret_cast<const char*>(&n), sizeof n);
  buf.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
template <class T>
bool get(const std::string& buf, size_t& at, std::vector<T>& v) {
  uint64_t n = 0;
  if (buf.size() - at < sizeof n) return false;
  std::memcpy(&n, buf.data() + at, sizeof n);
  at += sizeof n;
  if ((buf.size() - at) / sizeof(T) < n) return false;
  v.resize(size_t(n));
  std::memcpy(static_cast<void*>(v.data()), buf.data() + at, size_t(n) * sizeof(T));
  at += size_t(n) * sizeof(T);
  return true;
}

Tets run_forked(const std::string& switches, tetgenio& in) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error(std::string("TetGen: cannot make a pipe: ") + std::strerror(errno));
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    throw std::runtime_error(std::string("TetGen: cannot fork: ") + std::strerror(errno));
  }
  if (pid == 0) {  // the child: run, send, leave without destructors or atexit handlers
    close(fds[0]);
    for (int sig : {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);  // no inherited crash reports
    std::string buf;
    try {
      tetgenio out;
      run(switches, in, out);
      const Tets t = read_output(out);
      buf.push_back('\0');
      put(buf, t.points);
      put(buf, t.tets);
      put(buf, t.region);
      put(buf, t.faces);
      put(buf, t.face_marker);
    } catch (const std::exception& e) {
      buf.assign(1, '\1');
      buf += e.what();
    }
    for (size_t at = 0; at < buf.size();) {
      const ssize_t w = write(fds[1], buf.data() + at, buf.size() - at);
      if (w <= 0) {
        if (w < 0 && errno == EINTR) continue;
        _exit(3);
      }
      at += size_t(w);
    }
    _exit(0);
  }
  close(fds[1]);
  std::string buf;
  char chunk[1 << 16];
  for (;;) {
    const ssize_t r = read(fds[0], chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    buf.append(chunk, size_t(r));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status))
    throw std::runtime_error("TetGen (" + switches + ") died with signal " + std::to_string(WTERMSIG(status)) + " (" +
                             strsignal(WTERMSIG(status)) + "); it does so when it gives up on its input, e.g. when "
                             "input facets intersect");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || buf.empty())
    throw std::runtime_error("TetGen (" + switches + ") ended without a result");
  if (buf[0] == '\1') throw std::runtime_error(buf.substr(1));
  Tets t;
  size_t at = 1;
  if (!get(buf, at, t.points) || !get(buf, at, t.tets) || !get(buf, at, t.region) || !get(buf, at, t.faces) ||
      !get(buf, at, t.face_marker) || at != buf.size())
    throw std::runtime_error("TetGen (" + switches + "): truncated result from the child process");
  return t;
}

}  // namespace

Tets delaunay(const std::vector<glm::dvec3>& points) {
  if (points.size() < 4) throw std::runtime_error("Delaunay tetrahedralization needs at least 4 points, got " + std::to_string(points.size()));
  tetgenio in, out;
  set_points(in, points);
  run("Qz", in, out);
  Tets t = read_output(out);
  // TetGen lists the points it kept, in input order, and drops one that coincides with an earlier one; that shifted
  // every later index (seen on the 64^3 shells: two particles of the one-voxel shell at one float position
  // scrambled the mesh after the second, and its volume mesh never finished recovering the boundary). Each output
  // point is mapped to its input point by walking both lists, so a dropped point is in no tet.
  std::vector<uint32_t> input_at(t.points.size());
  size_t next = 0;
  for (size_t j = 0; j < t.points.size(); ++j) {
    while (next < points.size() && points[next] != t.points[j]) ++next;
    if (next == points.size()) throw std::runtime_error("TetGen (Qz) returned a point that is not in its input");
    input_at[j] = uint32_t(next++);
  }
  for (auto& tet : t.tets)
    for (auto& v : tet) v = input_at[v];
  t.points = points;  // no Steiner points: keep the exact input
  return t;
}

Tets constrained_quality(const std::vector<glm::dvec3>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                         const std::vector<int>& markers, const std::vector<Region>& regions,
                         const QualityOptions& options) {
  // TetGen's refinement is only known to end for looser bounds (1.1/20 ran without end on a small sphere).
  if (!(options.max_radius_edge >= 1.2) || !(options.min_dihedral <= 18.0) || options.min_dihedral < 0)
    throw std::invalid_argument("volume mesh: max radius-edge ratio must be >= 1.2 and min dihedral angle in [0, 18] "
                                "degrees, got " + std::to_string(options.max_radius_edge) + " and " +
                                std::to_string(options.min_dihedral));
  // Only the triangles' vertices go to TetGen. The caller's list also holds points no triangle uses (particles left
  // out near junctions, merged duplicates), and TetGen drops an input point that coincides with another from its
  // output list, which would shift every later index.
  std::vector<uint8_t> referenced(points.size(), 0);
  for (const auto& tri : triangles)
    for (uint32_t v : tri) referenced[v] = 1;
  std::vector<uint32_t> compact(points.size(), UINT32_MAX), used;  // caller index <-> TetGen index
  for (uint32_t v = 0; v < points.size(); ++v)
    if (referenced[v]) {
      compact[v] = uint32_t(used.size());
      used.push_back(v);
    }
  std::vector<glm::dvec3> used_points;
  for (uint32_t v : used) used_points.push_back(points[v]);
  tetgenio in;
  set_points(in, used_points);
  in.numberoffacets = int(triangles.size());
  in.facetlist = new tetgenio::facet[triangles.size()];
  in.facetmarkerlist = new int[triangles.size()];
  for (size_t i = 0; i < triangles.size(); ++i) {
    tetgenio::facet& f = in.facetlist[i];
    f.numberofpolygons = 1;
    f.polygonlist = new tetgenio::polygon[1];
    f.numberofholes = 0;
    f.holelist = nullptr;
    f.polygonlist[0].numberofvertices = 3;
    f.polygonlist[0].vertexlist = new int[3];
    for (int a = 0; a < 3; ++a) f.polygonlist[0].vertexlist[a] = int(compact[triangles[i][size_t(a)]]);
    in.facetmarkerlist[i] = markers.empty() ? 0 : markers[i];
  }
  in.numberofregions = int(regions.size());
  in.regionlist = new REAL[regions.size() * 5];
  for (size_t r = 0; r < regions.size(); ++r) {
    in.regionlist[5 * r + 0] = regions[r].seed.x;
    in.regionlist[5 * r + 1] = regions[r].seed.y;
    in.regionlist[5 * r + 2] = regions[r].seed.z;
    in.regionlist[5 * r + 3] = regions[r].attribute;
    in.regionlist[5 * r + 4] = -1;
  }
  std::ostringstream sw;
  sw << "pq" << options.max_radius_edge << "/" << options.min_dihedral << "AQz";
  if (options.max_volume > 0) sw << "a" << options.max_volume;
  if (options.keep_surface) sw << "Y";
  Tets t = run_forked(sw.str(), in);
  // TetGen keeps the input points first, in order, unless it jettisons some: points left outside every region,
  // which happens when a material's boundary is not closed and its region leaks into the outside. The caller's
  // triangles and fixed vertices would then index the wrong points.
  size_t kept = 0;
  while (kept < used.size() && kept < t.points.size() && t.points[kept] == used_points[kept]) ++kept;
  if (kept < used.size())
    throw std::runtime_error("TetGen dropped surface vertices (" + std::to_string(used.size()) + " given, the first " +
                             std::to_string(kept) + " kept in place): a material's boundary is not closed, so its "
                             "region leaked outside");
  // Back to the caller's numbering: all of its points first (those no triangle uses are in no tet), then the new ones.
  auto caller_index = [&](uint32_t j) {
    return j < used.size() ? used[j] : uint32_t(points.size() + (j - used.size()));
  };
  for (auto& tet : t.tets)
    for (auto& v : tet) v = caller_index(v);
  for (auto& f : t.faces)
    for (auto& v : f) v = caller_index(v);
  std::vector<glm::dvec3> all = points;
  all.insert(all.end(), t.points.begin() + std::ptrdiff_t(used.size()), t.points.end());
  t.points = std::move(all);
  return t;
}

}  // namespace cpmesh::mesh
