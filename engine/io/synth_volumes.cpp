#include "io/synth_volumes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include <nlohmann/json.hpp>

#include "io/atomic_file.h"
#include "io/error.h"
#include "io/synth_corpus.h"

namespace cpmesh::io {

namespace {

using Vec = std::array<double, 3>;
constexpr double pi = std::numbers::pi;
constexpr double wedge_rotation = 0.3;  // radians: keeps the wedge planes off the grid planes
constexpr int curve_samples = 257;

Vec add(const Vec& a, const Vec& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec scale(const Vec& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double dist(const Vec& a, const Vec& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }

template <size_t N>
std::array<uint16_t, N> sorted(std::array<uint16_t, N> m) {
  std::sort(m.begin(), m.end());
  return m;
}

struct WedgeBall {
  Vec centre, inner;
  double R, r;
  uint16_t label(const Vec& p) const {
    if (dist(p, inner) < r) return 4;
    if (dist(p, centre) >= R) return 0;
    double a = std::atan2(p[1] - centre[1], p[0] - centre[0]) - wedge_rotation;
    while (a < 0) a += 2 * pi;
    return uint16_t(1 + int(a / (2 * pi / 3)) % 3);
  }
};

Junctions wedge_ball_junctions(const WedgeBall& w) {
  Junctions j;
  const double dx = w.inner[0] - w.centre[0], dy = w.inner[1] - w.centre[1], dz = w.inner[2] - w.centre[2];
  const double half = std::sqrt(w.r * w.r - dx * dx - dy * dy);  // the axis enters the inner ball at dz +- half
  const Vec north = add(w.centre, {0, 0, w.R}), south = add(w.centre, {0, 0, -w.R});
  const Vec inner_top = {w.centre[0], w.centre[1], w.inner[2] + half};
  const Vec inner_bottom = {w.centre[0], w.centre[1], w.inner[2] - half};
  j.quadruple_points = {{{0, 1, 2, 3}, north}, {{0, 1, 2, 3}, south}, {{1, 2, 3, 4}, inner_top},
                        {{1, 2, 3, 4}, inner_bottom}};
  auto segment = [&](const Vec& a, const Vec& b) {
    TripleCurve c{{1, 2, 3}, {}};
    for (int s = 0; s < curve_samples; ++s) c.points.push_back(add(a, scale(add(b, scale(a, -1)), double(s) / (curve_samples - 1))));
    return c;
  };
  j.triple_curves.push_back(segment(north, inner_top));
  j.triple_curves.push_back(segment(inner_bottom, south));
  // Wedge boundary b lies at angle rotation + b * 120 degrees, between wedge (b + 2) % 3 + 1 and wedge b + 1.
  for (int b = 0; b < 3; ++b) {
    const double theta = wedge_rotation + b * 2 * pi / 3, ct = std::cos(theta), st = std::sin(theta);
    const uint16_t left = uint16_t((b + 2) % 3 + 1), right = uint16_t(b + 1);
    TripleCurve outer{sorted<3>({0, left, right}), {}};
    for (int s = 0; s < curve_samples; ++s) {
      const double phi = pi * s / (curve_samples - 1);
      outer.points.push_back(add(w.centre, {w.R * std::sin(phi) * ct, w.R * std::sin(phi) * st, w.R * std::cos(phi)}));
    }
    j.triple_curves.push_back(outer);
    // The half-plane meets the inner sphere in the part rho >= 0 of a circle (centre a, radius rp) in (rho, z).
    const double a = dx * ct + dy * st, perp = -dx * st + dy * ct;
    const double rp = std::sqrt(w.r * w.r - perp * perp), psi0 = std::acos(-a / rp);
    TripleCurve inner{sorted<3>({left, right, 4}), {}};
    for (int s = 0; s < curve_samples; ++s) {
      const double psi = psi0 - 2 * psi0 * s / (curve_samples - 1);
      const double rho = std::max(0.0, a + rp * std::cos(psi)), z = dz + rp * std::sin(psi);
      inner.points.push_back(add(w.centre, {rho * ct, rho * st, z}));
    }
    inner.points.front() = inner_top;
    inner.points.back() = inner_bottom;
    j.triple_curves.push_back(inner);
  }
  return j;
}

// Polynomial smooth minimum of two signed distances (blend width k): rounds the crease where two shapes join.
double smooth_min(double a, double b, double k) {
  const double t = std::clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);
  return b + (a - b) * t - k * t * (1 - t);
}

// The head phantom (see the header), in voxel units scaled by s = size / 250; every D below is a signed distance
// (negative inside), exact for the cylinders and radial (along the ray from the centre) for the ellipsoid.
struct Head {
  Vec centre;  // voxel units
  double s;
  uint16_t label(const Vec& v) const {
    const Vec q = {v[0] - centre[0], v[1] - centre[1], v[2] - centre[2]};
    const Vec axes = {78 * s, 100 * s, 90 * s};
    const double len = std::hypot(q[0], q[1], q[2]);
    const double rho = std::hypot(q[0] / axes[0], q[1] / axes[1], q[2] / axes[2]);
    const double d_ell = rho > 1e-12 ? len * (1 - 1 / rho) : -axes[0];
    // Vertical axis of the neck, the brainstem and its CSF sheath, behind the centre.
    const double r = std::hypot(q[0], q[1] - 12 * s);
    const double d_neck = std::max(r - 40 * s, q[2]);
    const double d_stem = std::max(r - 9 * s, q[2] + 40 * s);
    const double d_sheath = std::max(r - 14 * s, q[2] + 40 * s);
    const double thickness = 12 * s + 1.5 * s * std::sin(q[0] / (17 * s)) * std::cos(q[1] / (23 * s));
    const double l = 6 * s;  // gyri: a gyroid on the brain's surface, period 2 pi l
    const double g = std::sin(q[0] / l) * std::cos(q[1] / l) + std::sin(q[1] / l) * std::cos(q[2] / l) +
                     std::sin(q[2] / l) * std::cos(q[0] / l);
    const double d_brain = smooth_min(d_ell + thickness + 2.5 * s + 9 * s * (g + 1.5) / 3, d_stem, 8 * s);
    if (d_brain < 0) return 4;
    if (d_sheath < 0 || d_ell + thickness < 0) return 3;
    if (d_ell + 5 * s < 0) return 2;
    if (smooth_min(d_ell, d_neck, 14 * s) < 0) return 1;
    return 0;
  }
};

}  // namespace

double distance_to_triple_curve(const Junctions& j, const std::array<uint16_t, 3>& materials, const Vec& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& c : j.triple_curves) {
    if (c.materials != materials) continue;
    for (size_t i = 0; i + 1 < c.points.size(); ++i) {
      const Vec& a = c.points[i];
      const Vec ab = add(c.points[i + 1], scale(a, -1)), ap = add(p, scale(a, -1));
      const double len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
      const double t = std::clamp((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / std::max(len2, 1e-30), 0.0, 1.0);
      best = std::min(best, dist(p, add(a, scale(ab, t))));
    }
  }
  return best;
}

namespace {
constexpr std::array<std::pair<SynthShape, const char*>, 9> kShapeNames = {{{SynthShape::sphere, "sphere"},
                                                                           {SynthShape::wedge_ball, "wedge-ball"},
                                                                           {SynthShape::slabs, "slabs"},
                                                                           {SynthShape::shells, "shells"},
                                                                           {SynthShape::head, "head"},
                                                                           {SynthShape::parcellation, "parcellation"},
                                                                           {SynthShape::thin, "thin"},
                                                                           {SynthShape::islands, "islands"},
                                                                           {SynthShape::organs, "organs"}}};
}  // namespace

const char* synth_shape_name(SynthShape s) {
  for (const auto& [shape, name] : kShapeNames)
    if (shape == s) return name;
  return "?";
}

SynthShape parse_synth_shape(const std::string& name) {
  if (name == "wedge_ball") return SynthShape::wedge_ball;
  std::string known;
  for (const auto& [shape, n] : kShapeNames) {
    if (name == n) return shape;
    known += (known.empty() ? "" : ", ") + std::string(n);
  }
  throw Error("field 'shape': expected one of " + known + ", got '" + name + "'");
}

void check_synth_options(const SynthOptions& o) {
  if (o.size < 4 || o.size > 2048) throw Error("field 'size': expected 4..2048 voxels, got '" + std::to_string(o.size) + "'");
  for (double s : o.spacing)
    if (!(s > 0) || !std::isfinite(s)) throw Error("field 'spacing': expected positive spacings");
  if (!(o.radius >= 0)) throw Error("field 'radius': expected a positive radius in voxels");
  if (o.labels != 0 && (o.labels < 2 || o.labels > 1000))
    throw Error("field 'labels': expected 2..1000 parcels, got '" + std::to_string(o.labels) + "'");
  if (!(o.noise >= 0 && o.noise <= 0.5)) throw Error("field 'noise': expected a share in 0..0.5");
}

SynthVolume make_synth_volume(const SynthOptions& o) {
  check_synth_options(o);
  SynthVolume out;
  LabelVolume& v = out.volume;
  v.dims = {o.size, o.size, o.size};
  if (o.shape == SynthShape::organs)  // a CT field of view: wide, shallower, few slices
    v.dims = {o.size, std::max<int64_t>(4, std::llround(o.size * 0.806)), std::max<int64_t>(4, std::llround(o.size * 0.377))};
  if (o.shape == SynthShape::head)  // the seed paper's head is 199 x 250 x 249 voxels
    v.dims = {std::max<int64_t>(4, std::llround(o.size * 199.0 / 250)), o.size,
              std::max<int64_t>(4, std::llround(o.size * 249.0 / 250))};
  v.spacing = o.spacing;
  v.format = "synthetic";
  v.file_type = ScalarType::u8;
  v.labels.assign(size_t(v.voxel_count()), 0);
  if (is_corpus_shape(o.shape)) {
    std::string params;
    make_corpus_volume(o, v, params);
    out.description = params;
    return out;
  }
  const double h = std::min({o.spacing[0], o.spacing[1], o.spacing[2]});
  const double n = double(o.size);
  // Off-grid centre (as in analytic_volumes.h) so no interface passes exactly through voxel centres.
  const Vec centre = {(n - 1) / 2 * o.spacing[0] + 0.1 * h, (n - 1) / 2 * o.spacing[1] - 0.2 * h,
                      (n - 1) / 2 * o.spacing[2] + 0.15 * h};
  out.centre = centre;
  nlohmann::json params;
  params["centre"] = centre;
  std::function<uint16_t(const Vec&)> label;
  WedgeBall w{};
  switch (o.shape) {
    case SynthShape::sphere: {
      const double R = (o.radius > 0 ? o.radius : 0.35 * n) * h;
      params["radius"] = R;
      label = [=](const Vec& p) { return uint16_t(dist(p, centre) < R ? 1 : 0); };
      break;
    }
    case SynthShape::wedge_ball: {
      w.centre = centre;
      w.R = (o.radius > 0 ? o.radius : 50.0 * n / 128.0) * h;
      w.r = w.R * 18.0 / 50.0;
      w.inner = add(centre, scale({6, 4, 5}, w.R / 50.0));
      params["radius"] = w.R;
      params["inner_centre"] = w.inner;
      params["inner_radius"] = w.r;
      params["wedge_rotation"] = wedge_rotation;
      label = [w](const Vec& p) { return w.label(p); };
      out.junctions = wedge_ball_junctions(w);
      break;
    }
    case SynthShape::slabs: {
      const double ez = (n - 1) * o.spacing[2], z1 = 0.3 * ez + 0.25 * h, z2 = 0.5 * ez + 0.25 * h;
      const std::array<double, 4> bounds = {z1, z2, z2 + 2 * o.spacing[2], z2 + 3 * o.spacing[2]};
      params["z_boundaries"] = bounds;
      label = [=](const Vec& p) {
        uint16_t l = 1;
        for (double b : bounds) l = uint16_t(l + (p[2] >= b ? 1 : 0));
        return l;
      };
      break;
    }
    case SynthShape::head: {
      const double s = n / 250;
      // Off-grid like the others; the top of the skull 12 s voxels below the top face, the neck down to z = 0.
      const Vec c = {(double(v.dims[0]) - 1) / 2 + 0.1, (n - 1) / 2 - 0.2, double(v.dims[2]) - 1 - 102 * s + 0.15};
      out.centre = {c[0] * h, c[1] * h, c[2] * h};
      params["centre"] = out.centre;
      params["scale"] = s;
      const Head head{c, s};
      label = [head, h](const Vec& p) { return head.label({p[0] / h, p[1] / h, p[2] / h}); };
      break;
    }
    case SynthShape::shells: {
      const double R = (o.radius > 0 ? o.radius : 0.45 * n) * h;
      const std::array<double, 5> radii = {0.35 * R, 0.55 * R, 0.55 * R + 1.5 * h, 0.8 * R, 0.8 * R + 1.0 * h};
      params["radii"] = radii;
      params["radius"] = R;
      label = [=](const Vec& p) {
        const double d = dist(p, centre);
        if (d >= R) return uint16_t(0);
        uint16_t l = 1;
        for (double b : radii) l = uint16_t(l + (d >= b ? 1 : 0));
        return uint16_t(l > 5 ? 4 : l);  // between the thin shell 5 and the outer radius: shell 4 again
      };
      break;
    }
    default:
      break;  // the corpus kinds returned above
  }
  for (int64_t k = 0; k < v.dims[2]; ++k)
    for (int64_t j = 0; j < v.dims[1]; ++j)
      for (int64_t i = 0; i < v.dims[0]; ++i) v.labels[v.index(i, j, k)] = label(v.position(i, j, k));
  params["shape"] = synth_shape_name(o.shape);
  out.description = params.dump();
  return out;
}

void write_junctions_json(const std::string& path, const SynthVolume& s) {
  nlohmann::json j;
  j["units"] = "physical (voxel (i,j,k) centre at origin + (i,j,k) * spacing)";
  j["dims"] = s.volume.dims;
  j["spacing"] = s.volume.spacing;
  j["origin"] = s.volume.origin;
  j["parameters"] = nlohmann::json::parse(s.description);
  j["quadruple_points"] = nlohmann::json::array();
  for (const auto& q : s.junctions.quadruple_points)
    j["quadruple_points"].push_back({{"materials", q.materials}, {"position", q.position}});
  j["triple_curves"] = nlohmann::json::array();
  for (const auto& c : s.junctions.triple_curves)
    j["triple_curves"].push_back({{"materials", c.materials}, {"points", c.points}});
  const std::string text = j.dump();
  write_atomically(path, [&](std::ostream& out) { out << text << '\n'; });
}

}  // namespace cpmesh::io
