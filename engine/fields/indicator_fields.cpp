#include "fields/indicator_fields.h"

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <limits>
#include <map>

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include "fields/distance_transform.h"

namespace cpmesh::fields {

namespace {

struct Box {
  glm::ivec3 lo{std::numeric_limits<int>::max()}, hi{std::numeric_limits<int>::min()};  // inclusive
  glm::ivec3 size() const { return hi - lo + 1; }
};

// Separable Gaussian along one axis of a crop, in place, lines in parallel. Samples beyond the crop repeat the edge.
void gaussian_pass(std::vector<float>& f, const glm::ivec3& n, int axis, double sigma) {
  if (sigma <= 0) return;
  const int radius = int(std::ceil(3.0 * sigma));
  std::vector<double> w(size_t(2 * radius + 1));
  double total = 0;
  for (int r = -radius; r <= radius; ++r) total += w[size_t(r + radius)] = std::exp(-0.5 * r * r / (sigma * sigma));
  for (auto& x : w) x /= total;
  const int len = n[axis];
  const int a = axis == 0 ? 1 : 0, b = axis == 2 ? 1 : 2;
  const size_t strides[3] = {1, size_t(n.x), size_t(n.x) * size_t(n.y)};
  tbb::parallel_for(tbb::blocked_range2d<int>(0, n[b], 0, n[a]), [&](const tbb::blocked_range2d<int>& r) {
    std::vector<float> line(static_cast<size_t>(len));
    for (int jb = r.rows().begin(); jb < r.rows().end(); ++jb)
      for (int ja = r.cols().begin(); ja < r.cols().end(); ++ja) {
        float* p = f.data() + size_t(jb) * strides[b] + size_t(ja) * strides[a];
        const size_t s = strides[axis];
        for (int q = 0; q < len; ++q) line[size_t(q)] = p[size_t(q) * s];
        for (int q = 0; q < len; ++q) {
          double acc = 0;
          for (int r2 = -radius; r2 <= radius; ++r2)
            acc += w[size_t(r2 + radius)] * line[size_t(std::clamp(q + r2, 0, len - 1))];
          p[size_t(q) * s] = float(acc);
        }
      }
  });
}

}  // namespace

int IndicatorFields::material_at(const glm::dvec3& ijk) const {
  int best = 0;
  double best_value = -std::numeric_limits<double>::infinity();
  for (size_t m = 0; m < fields.size(); ++m) {
    const double v = fields[m].sample_linear(ijk);
    if (v > best_value) {
      best_value = v;
      best = int(m);
    }
  }
  return best;
}

size_t IndicatorFields::memory_bytes() const {
  size_t total = 0;
  for (const auto& f : fields) total += f.memory_bytes();
  return total;
}

IndicatorFields build_indicator_fields(const Grid& grid, const uint16_t* labels, const IndicatorOptions& options) {
  IndicatorFields out;
  out.grid = grid;
  const double h = grid.min_spacing();
  out.band = options.band * h;
  const float band = float(out.band);

  // Labels present, their voxel counts and bounding boxes.
  std::map<uint16_t, std::pair<uint64_t, Box>> found;
  for (int k = 0; k < grid.dims.z; ++k)
    for (int j = 0; j < grid.dims.y; ++j)
      for (int i = 0; i < grid.dims.x; ++i) {
        auto& [count, box] = found[labels[grid.index(i, j, k)]];
        ++count;
        box.lo = glm::min(box.lo, glm::ivec3(i, j, k));
        box.hi = glm::max(box.hi, glm::ivec3(i, j, k));
      }

  // Distance to the junctions (voxel corners where three or more labels meet). Near them the smoothing is faded
  // out: smoothing each material's distance field alone rounds every wedge-shaped edge of a material and so moves
  // triple curves and quadruple points (about 0.6 voxel into the convex side at sigma = 1); the unsmoothed distance
  // fields meet at the right place.
  std::vector<float> junction_distance;
  if (options.junction_fade > 0) {
    junction_distance.assign(grid.voxel_count(), std::numeric_limits<float>::infinity());
    for (int k = 0; k + 1 < grid.dims.z; ++k)
      for (int j = 0; j + 1 < grid.dims.y; ++j)
        for (int i = 0; i + 1 < grid.dims.x; ++i) {
          uint16_t seen[8];
          if (grid.corner_labels(i, j, k, [&](size_t v) { return labels[v]; }, seen) < 3) continue;
          for (int c = 0; c < 8; ++c) junction_distance[grid.index(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2))] = 0;
        }
    squared_distance_transform(grid, junction_distance);
  }
  const double fade = options.junction_fade * h;
  const double sigma_phys = options.smoothing_sigma * h;
  const int margin = int(std::ceil(options.band + 3.0 * options.smoothing_sigma)) + 2;
  for (const auto& [label, info] : found) {
    const auto& [count, box] = info;
    out.labels.push_back(label);
    out.voxel_counts.push_back(count);
    BrickField field(grid, -band);

    // The crop: the label's bounding box plus what the band and the smoothing can reach.
    Box crop{glm::max(box.lo - margin, glm::ivec3(0)), glm::min(box.hi + margin, grid.dims - 1)};
    const glm::ivec3 n = crop.size();
    Grid cgrid{n, grid.spacing, grid.origin};
    const size_t cn = cgrid.voxel_count();
    auto full_index = [&](size_t ci) {  // crop voxel -> the volume's voxel index
      const glm::ivec3 v = crop.lo + cgrid.voxel(ci);
      return grid.index(v.x, v.y, v.z);
    };
    constexpr float inf = std::numeric_limits<float>::infinity();
    std::vector<float> to_inside(cn), to_outside(cn);
    std::vector<uint8_t> inside(cn);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t ci = r.begin(); ci < r.end(); ++ci) {
        inside[ci] = labels[full_index(ci)] == label;
        to_inside[ci] = inside[ci] ? 0.0f : inf;
        to_outside[ci] = inside[ci] ? inf : 0.0f;
      }
    });
    squared_distance_transform(cgrid, to_inside);
    squared_distance_transform(cgrid, to_outside);
    // Signed distance to the mask boundary, which lies half a voxel beyond the boundary voxels' centres.
    std::vector<float>& phi = to_inside;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t ci = r.begin(); ci < r.end(); ++ci) {
        const double d = inside[ci] ? std::sqrt(double(to_outside[ci])) - 0.5 * h : -(std::sqrt(double(phi[ci])) - 0.5 * h);
        phi[ci] = float(std::clamp(d, -double(band), double(band)));
      }
    });
    to_outside = {};
    // Constrained smoothing: no voxel centre changes side.
    const float keep = float(1e-3 * h);
    const std::vector<float> raw = junction_distance.empty() ? std::vector<float>() : phi;
    for (int it = 0; it < options.smoothing_iterations; ++it) {
      for (int axis = 0; axis < 3; ++axis) gaussian_pass(phi, n, axis, sigma_phys / grid.spacing[axis]);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cn), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci < r.end(); ++ci) {
          if (!raw.empty()) {
            const double d = std::sqrt(double(junction_distance[full_index(ci)]));
            const double w = std::clamp(d / fade, 0.0, 1.0);
            const double smooth = 0.3 + 0.7 * w * w * (3 - 2 * w);  // never fully raw: 30% keeps the staircase down
            phi[ci] = float(smooth * phi[ci] + (1 - smooth) * raw[ci]);
          }
          phi[ci] = inside[ci] ? std::max(phi[ci], keep) : std::min(phi[ci], -keep);
        }
      });
    }

    // Into bricks: allocate those where the field is not a constant +-band.
    const glm::ivec3 blo = crop.lo / BrickField::kBrick, bhi = crop.hi / BrickField::kBrick;
    for (int bz = blo.z; bz <= bhi.z; ++bz)
      for (int by = blo.y; by <= bhi.y; ++by)
        for (int bx = blo.x; bx <= bhi.x; ++bx) {
          const glm::ivec3 b(bx, by, bz);
          const glm::ivec3 v0 = b * BrickField::kBrick, v1 = glm::min(v0 + BrickField::kBrick, grid.dims) - 1;
          bool varies = false, all_inside = true;
          for (int k = v0.z; k <= v1.z; ++k)
            for (int j = v0.y; j <= v1.y; ++j)
              for (int i = v0.x; i <= v1.x; ++i) {
                const glm::ivec3 c = glm::ivec3(i, j, k) - crop.lo;
                if (glm::any(glm::lessThan(c, glm::ivec3(0))) || glm::any(glm::greaterThanEqual(c, n))) {
                  all_inside = false;  // beyond the crop: far outside the material
                  continue;
                }
                const float v = phi[(size_t(c.z) * size_t(n.y) + size_t(c.y)) * size_t(n.x) + size_t(c.x)];
                if (std::fabs(v) < band) varies = true;
                if (v < 0) all_inside = false;
              }
          if (!varies) {
            field.set_brick_constant(b, all_inside ? band : -band);
            continue;
          }
          field.allocate(b);
          for (int k = v0.z; k <= v1.z; ++k)
            for (int j = v0.y; j <= v1.y; ++j)
              for (int i = v0.x; i <= v1.x; ++i) {
                const glm::ivec3 c = glm::ivec3(i, j, k) - crop.lo;
                const bool in_crop = !glm::any(glm::lessThan(c, glm::ivec3(0))) && !glm::any(glm::greaterThanEqual(c, n));
                field.set(i, j, k, in_crop ? phi[(size_t(c.z) * size_t(n.y) + size_t(c.y)) * size_t(n.x) + size_t(c.x)] : -band);
              }
        }
    out.fields.push_back(std::move(field));
  }
  return out;
}

}  // namespace cpmesh::fields
