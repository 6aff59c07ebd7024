#include "particles/population.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "host/host_array.h"
#include "ref/cp_lookup.h"

namespace cpmesh::particles {

namespace {

constexpr float kSupport = 1.7320508075688772f;  // the energy reaches sqrt(3) h (2 cos(pi/6) h)

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

float pair_energy(float d) {
  const float pi = 3.14159265358979f;
  d = std::max(d, 1e-3f);
  if (d >= 1.0f) return 0.0f;
  const float x = d * pi * 0.5f;
  return std::cos(x) / std::sin(x) + x - pi * 0.5f;
}

int feature_dimension(fields::FeatureKind kind) {
  return kind == fields::FeatureKind::interface ? 2 : kind == fields::FeatureKind::triple_curve ? 1 : 0;
}

double lattice_energy(double spacing, int dim) {
  double e = 0;
  const int reach = int(std::ceil(double(kSupport) / spacing)) + 1;
  if (dim == 1) {
    for (int k = 1; k <= reach; ++k) e += 2.0 * pair_energy(float(k * spacing / kSupport));
  } else if (dim == 2) {
    for (int a = -reach; a <= reach; ++a)
      for (int b = -reach; b <= reach; ++b) {
        if (a == 0 && b == 0) continue;
        const double x = a + 0.5 * b, y = 0.8660254037844386 * b;  // hexagonal lattice
        e += pair_energy(float(spacing * std::sqrt(x * x + y * y) / kSupport));
      }
  }
  return e;
}

double ideal_energy(fields::FeatureKind kind) { return lattice_energy(1.0, feature_dimension(kind)); }

double density_ratio(double energy_ratio, int dim) {
  if (dim == 0) return 1.0;
  const double target = energy_ratio * lattice_energy(1.0, dim);
  double lo = 0.2, hi = kSupport;  // lattice_energy decreases with the spacing; 0 from sqrt(3) on
  if (lattice_energy(lo, dim) <= target) return std::pow(1.0 / lo, dim);
  if (target <= 0) return std::pow(1.0 / hi, dim);
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (lattice_energy(mid, dim) > target ? lo : hi) = mid;
  }
  return std::pow(2.0 / (lo + hi), dim);
}

std::vector<float> feature_ideals(const fields::ClosestPointEmbedding& E) {
  std::vector<float> out;
  for (const auto& f : E.features) out.push_back(float(ideal_energy(f.kind)));
  return out;
}

// ---------------------------------------------------------------------------------------------------------------

HostIndex::HostIndex(const fields::ClosestPointEmbedding& E, double cell) : cell_(cell) {
  masks_ = fields::material_sets(E.features);
}

glm::ivec3 HostIndex::cell_of(const glm::vec3& p) const { return glm::ivec3(glm::floor(glm::dvec3(p) / cell_)); }

uint64_t HostIndex::key(const glm::ivec3& c) { return fields::cell_key(c); }

namespace {
size_t cell_hash(uint64_t key) {  // splitmix64's finaliser
  key ^= key >> 30;
  key *= 0xbf58476d1ce4e5b9ull;
  key ^= key >> 27;
  key *= 0x94d049bb133111ebull;
  return size_t(key ^ (key >> 31));
}
}  // namespace

size_t HostIndex::find(uint64_t k) const {
  if (table_.empty()) return kNoSlot;
  const size_t mask = table_.size() - 1;
  for (size_t slot = cell_hash(k) & mask;; slot = (slot + 1) & mask) {
    if (table_[slot].head == kNone) return kNoSlot;
    if (table_[slot].key == k) return slot;
  }
}

uint32_t HostIndex::insert(const glm::vec4& particle, uint32_t feature) {
  const uint32_t id = uint32_t(entries_.size());
  entries_.push_back({particle, feature, true, kNone});
  if (2 * (cells_used_ + 1) > table_.size()) {  // grow: rehash the cells into a table twice the size
    std::vector<Cell> old(std::max<size_t>(64, table_.size() * 2));
    old.swap(table_);
    used_slots_.clear();
    for (const Cell& c : old) {
      if (c.head == kNone) continue;
      size_t slot = cell_hash(c.key) & (table_.size() - 1);
      while (table_[slot].head != kNone) slot = (slot + 1) & (table_.size() - 1);
      table_[slot] = c;
      used_slots_.push_back(slot);
    }
  }
  const uint64_t k = key(cell_of(glm::vec3(particle)));
  size_t slot = cell_hash(k) & (table_.size() - 1);
  while (table_[slot].head != kNone && table_[slot].key != k) slot = (slot + 1) & (table_.size() - 1);
  Cell& c = table_[slot];
  if (c.head == kNone) {
    c = {k, id, id};
    ++cells_used_;
    used_slots_.push_back(slot);
  } else {
    entries_[c.tail].next = id;
    c.tail = id;
  }
  h_max_ = std::max(h_max_, particle.w);
  ++live_;
  return id;
}

void HostIndex::clear() {
  for (size_t slot : used_slots_) table_[slot] = Cell{};
  used_slots_.clear();
  entries_.clear();
  cells_used_ = 0;
  live_ = 0;
  h_max_ = 0;
}

void HostIndex::remove(uint32_t id) {
  Entry& e = entries_[id];
  if (!e.live) return;
  e.live = false;  // stays in its cell's list; for_each_near skips it
  --live_;
}

double HostIndex::energy(const glm::vec3& p, float h, uint32_t feature, uint32_t skip) const {
  const fields::MaterialSet mask = masks_[feature];
  // Pairs interact within sqrt(3) min(h, h_j) <= sqrt(3) h.
  double e = 0;
  for_each_near(p, kSupport * std::min(h, h_max_), [&](uint32_t j, const Entry& q) {
    if (j == skip || !masks_[q.feature].includes(mask)) return;
    const float r = glm::length(p - glm::vec3(q.particle));
    e += pair_energy(r / (kSupport * std::min(h, q.particle.w)));
  });
  return e;
}

std::optional<glm::vec3> HostIndex::nearest(const glm::vec3& p, uint32_t feature, float radius) const {
  std::optional<glm::vec3> best;
  float best_d = radius;
  for_each_near(p, radius, [&](uint32_t, const Entry& q) {
    if (q.feature != feature) return;
    const float d = glm::length(p - glm::vec3(q.particle));
    if (d <= best_d) best_d = d, best = glm::vec3(q.particle);
  });
  return best;
}

// ---------------------------------------------------------------------------------------------------------------

namespace {

// A cell size for the host index: sqrt(3) x the median h of the embedding's touching blocks.
double typical_cell(const fields::ClosestPointEmbedding& E) {
  std::vector<float> hs;
  const size_t per_block = size_t(E.sub * E.sub * E.sub);
  for (size_t slot = 0; slot < E.keys.size(); slot += 7)
    if (E.keys[slot] != fields::ClosestPointEmbedding::kEmpty) hs.push_back(E.fine[size_t(E.blocks[slot]) * per_block].w);
  if (hs.empty()) return 1.0;
  std::nth_element(hs.begin(), hs.begin() + long(hs.size() / 2), hs.end());
  return std::max(double(kSupport) * hs[hs.size() / 2], 1e-6);
}

// h at a quadruple point: the sizing stored with its own feature's closest points.
float quadruple_h(const fields::ClosestPointEmbedding& E, const glm::dvec3& p, uint32_t feature) {
  const auto cp = ref::cp_lookup(E, glm::vec3(p), feature);
  if (cp.valid && cp.value.w > 0) return cp.value.w;
  return float(E.grid.min_spacing());
}

// Work items in tiles of width `tile` by position, the tiles grouped by parity (tile coordinates mod 2: 8 classes).
// Two tiles of one parity are at least `tile` apart, so work whose reads and writes stay within that of its items
// runs on the tiles of one parity side by side (run_by_parity). Items keep their given order within a tile.
struct Tiles {
  std::vector<uint32_t> item;     // the items, parity by parity, tile by tile
  std::vector<size_t> begin;      // tile t holds item[begin[t] .. begin[t + 1])
  std::vector<size_t> parity;     // the tiles of parity class c are [parity[c], parity[c + 1])
  size_t count() const { return begin.size() - 1; }
};

template <class Position>
Tiles tile_by_parity(const std::vector<uint32_t>& items, double tile, Position&& position) {
  struct Keyed {
    uint64_t key;  // parity in the top 3 bits, then the tile
    uint32_t place;  // in `items`: ties keep the given order (a stable sort, on every core)
    uint32_t item;
  };
  std::vector<Keyed> order(items.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, items.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k < r.end(); ++k) {
      const glm::ivec3 t(glm::floor(glm::dvec3(position(items[k])) / tile));
      const uint64_t parity = uint64_t(t.x & 1) | uint64_t(t.y & 1) << 1 | uint64_t(t.z & 1) << 2;
      order[k] = {parity << 61 | (fields::cell_key(t) & ((uint64_t(1) << 61) - 1)), uint32_t(k), items[k]};
    }
  });
  tbb::parallel_sort(order.begin(), order.end(),
                     [](const Keyed& a, const Keyed& b) { return a.key != b.key ? a.key < b.key : a.place < b.place; });
  Tiles out;
  out.item.resize(order.size());
  std::vector<uint64_t> tile_parity;
  for (size_t k = 0; k < order.size(); ++k) {
    out.item[k] = order[k].item;
    if (k > 0 && order[k].key == order[k - 1].key) continue;
    out.begin.push_back(k);
    tile_parity.push_back(order[k].key >> 61);
  }
  out.begin.push_back(order.size());
  for (uint64_t c = 0; c <= 8; ++c)
    out.parity.push_back(size_t(std::lower_bound(tile_parity.begin(), tile_parity.end(), c) - tile_parity.begin()));
  return out;
}

// Parity by parity: work(t) on the parity's tiles in parallel, then join(t) on them in tile order (serially). The
// result does not depend on the thread count when work(t) reads only what earlier parities' joins left and writes
// only its own tile's state.
template <class Work, class Join>
void run_by_parity(const Tiles& tiles, Work&& work, Join&& join) {
  for (size_t c = 0; c < 8; ++c) {
    const size_t first = tiles.parity[c], last = tiles.parity[c + 1];
    tbb::parallel_for(tbb::blocked_range<size_t>(first, last, 1), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t < r.end(); ++t) work(t);
    });
    for (size_t t = first; t < last; ++t) join(t);
  }
}

// A small counter-based generator (splitmix64: a Weyl sequence through cell_hash, its finaliser) for the per-item
// random streams of parallel steps.
struct SplitMix {
  using result_type = uint64_t;
  uint64_t state;
  static constexpr uint64_t min() { return 0; }
  static constexpr uint64_t max() { return ~uint64_t(0); }
  uint64_t operator()() { return cell_hash(state += 0x9e3779b97f4a7c15ull); }
};

}  // namespace

Population seed_population(const fields::ClosestPointEmbedding& E, const PopulationOptions& options, SeedStats* stats,
                           bool grid_only) {
  Population out;
  SeedStats st;
  const double index_cell = typical_cell(E);
  HostIndex index(E, index_cell);
  std::mt19937 rng(options.seed);
  const double voxel = E.grid.min_spacing();
  const size_t per_block = size_t(E.sub * E.sub * E.sub);
  auto keep = [&](const glm::vec4& p, uint32_t f) {
    out.particles.push_back(p);
    out.features.push_back(f);
    index.insert(p, f);
  };
  for (const auto& q : E.quadruple_points) keep(glm::vec4(glm::vec3(q.position), quadruple_h(E, q.position, q.feature)), q.feature);

  for (fields::FeatureKind kind : {fields::FeatureKind::triple_curve, fields::FeatureKind::interface}) {
    // Candidates of this dimension: grid points next to the feature, projected (the stored closest point of the
    // block's first fine point), and random points in the cells where h is small, projected by the lookup. The
    // slots are found in chunks of the hash table, in parallel, and kept in slot order. They are independent (each
    // draws from its own generator, seeded by the run's seed and the slot), so they run in parallel too, and their
    // candidates are joined in slot order: the same candidates on any number of threads.
    const std::vector<size_t> slots =
        collect_in_order_by_index<size_t>(E.keys.size(), size_t(1) << 14, [&](size_t slot, auto& out_here) {
          if (E.keys[slot] == fields::ClosestPointEmbedding::kEmpty) return;
          const uint32_t f = uint32_t(E.keys[slot] & 0xffff);
          if (E.features[f].kind != kind) return;
          if (E.touches_feature(size_t(E.keys[slot] >> 16), E.blocks[slot])) out_here.push_back(slot);
        });
    std::vector<std::pair<glm::vec4, uint32_t>> candidates = collect_in_order_by_index<std::pair<glm::vec4, uint32_t>>(
        slots.size(), 256, [&](size_t k, auto& out_here) {
          const size_t slot = slots[k];
          const uint32_t f = uint32_t(E.keys[slot] & 0xffff);
          const size_t cell = size_t(E.keys[slot] >> 16);
          const glm::vec4 cp = E.fine[size_t(E.blocks[slot]) * per_block];
          out_here.push_back({cp, f});
          if (grid_only) return;
          const double h_vox = cp.w / voxel;
          if (h_vox >= options.random_seed_below) return;
          std::mt19937 slot_rng(uint32_t(options.seed) * 0x9E3779B1u ^ uint32_t(slot) * 0x85EBCA77u ^
                                uint32_t(slot >> 32));
          std::uniform_real_distribution<float> u01(0.0f, 1.0f);
          const double expected = options.random_seed_constant / std::max(h_vox, 1e-3);
          int count = int(expected);
          if (u01(slot_rng) < expected - count) ++count;
          const glm::vec3 corner = glm::vec3(E.grid.local(glm::dvec3(E.grid.voxel(cell)) - 0.5));
          for (int c = 0; c < count; ++c) {
            const float a = u01(slot_rng), b = u01(slot_rng), d = u01(slot_rng);
            const glm::vec3 q = corner + glm::vec3(a, b, d) * glm::vec3(E.grid.spacing);
            const auto res = ref::cp_lookup(E, q, f);
            if (res.valid) out_here.push_back({res.value, f});
          }
        });
    st.grid_candidates += slots.size();
    st.random_candidates += candidates.size() - slots.size();
    std::shuffle(candidates.begin(), candidates.end(), rng);  // no grid-aligned bias in who is kept
    st.candidates += candidates.size();
    if (grid_only) {
      for (const auto& [p, f] : candidates) keep(p, f);
      continue;
    }
    // The energy test in parallel. Candidates go into tiles at least as wide as the largest reach of a pair
    // (sqrt(3) h_max); a tile's candidates see only particles in its own and the 26 tiles around it. Tiles of 8 index
    // cells at least: the tiled order packs denser than one random sequence where tiles hold few particles (tiles
    // of sqrt(3) h_max kept 4-9% more seeds at uniform sizing, and 128^3 at h <= 2 then took 80 iterations instead
    // of 50); with 8 cells, 0.6% and 1.6% more (64^3 at h = 0.5, 128^3 at h <= 2). Tiles of one of
    // the 8 parities share no neighbour, so a parity's tiles are tested side by side, each against the particles
    // kept before this parity (the shared index, read only) and its own kept ones (a scratch index), candidates in
    // their shuffled order; then they join the shared index in tile order. Same result on any thread count.
    const double ideal = ideal_energy(kind);
    float h_max = 0;
    for (const auto& c : candidates) h_max = std::max(h_max, c.first.w);
    const double tile = std::max(double(kSupport) * h_max, 8.0 * index_cell);
    std::vector<uint32_t> all(candidates.size());
    std::iota(all.begin(), all.end(), 0u);
    const Tiles tiles = tile_by_parity(all, tile, [&](uint32_t c) { return glm::vec3(candidates[c].first); });
    std::vector<uint8_t> kept(candidates.size(), 0);
    tbb::enumerable_thread_specific<HostIndex> scratch(E, index_cell);
    run_by_parity(
        tiles,
        [&](size_t t) {
          HostIndex& mine = scratch.local();
          mine.clear();
          for (size_t k = tiles.begin[t]; k < tiles.begin[t + 1]; ++k) {
            const auto& [p, f] = candidates[tiles.item[k]];
            const double e = index.energy(glm::vec3(p), p.w, f) + mine.energy(glm::vec3(p), p.w, f);
            if (e >= options.seed_energy_factor * ideal) continue;
            mine.insert(p, f);
            kept[tiles.item[k]] = 1;
          }
        },
        [&](size_t t) {
          for (size_t k = tiles.begin[t]; k < tiles.begin[t + 1]; ++k)
            if (kept[tiles.item[k]]) keep(candidates[tiles.item[k]].first, candidates[tiles.item[k]].second);
        });
  }
  st.kept = out.particles.size();
  if (stats) *stats = st;
  return out;
}

// ---------------------------------------------------------------------------------------------------------------

Population add_delete(const fields::ClosestPointEmbedding& E, const Population& pop, const std::vector<float>& energies,
                      const std::vector<uint32_t>& flags, const std::vector<double>& feature_ratio,
                      const PopulationOptions& options, std::mt19937& rng, RoundReport& report) {
  const size_t n = pop.particles.size();
  const double index_cell = typical_cell(E);
  HostIndex index(E, index_cell);
  std::vector<uint32_t> id(n);  // each particle's id in the index (a re-inserted particle gets a new one)
  for (size_t i = 0; i < n; ++i) id[i] = index.insert(pop.particles[i], pop.features[i]);
  std::vector<uint8_t> alive(n, 1);
  auto ideal_of = [&](size_t i) { return ideal_energy(E.features[pop.features[i]].kind); };
  auto current = [&](size_t i) {
    return index.energy(glm::vec3(pop.particles[i]), pop.particles[i].w, pop.features[i], id[i]);
  };
  std::vector<size_t> by_energy(n);
  std::iota(by_energy.begin(), by_energy.end(), size_t(0));
  std::stable_sort(by_energy.begin(), by_energy.end(), [&](size_t a, size_t b) { return energies[a] < energies[b]; });

  // Per feature: particles and the count change its mean energy asks for (negative: too many).
  const size_t F = E.features.size();
  std::vector<long> count(F, 0), change(F, 0);
  for (size_t i = 0; i < n; ++i) ++count[pop.features[i]];
  for (size_t f = 0; f < F; ++f) {
    const int dim = feature_dimension(E.features[f].kind);
    if (dim == 0 || count[f] < options.min_feature_particles) continue;
    const double ratio = (f < feature_ratio.size() ? feature_ratio[f] : 1.0) / options.relaxed_energy_ratio;
    if (std::fabs(ratio - 1.0) <= options.energy_tolerance) continue;
    const double density = density_ratio(ratio, dim);  // > 1: denser than ideal
    change[f] = std::lround(options.count_gain * double(count[f]) * (1.0 / density - 1.0));
    change[f] = std::clamp(change[f], -count[f] / 2, count[f]);
  }

  // a. The paper's step: delete candidates out, then back in one at a time, lowest energy first, if below 4x ideal.
  for (size_t i = 0; i < n; ++i)
    if (flags[i] == 1) index.remove(id[i]);
  for (size_t i : by_energy) {
    if (flags[i] != 1) continue;
    if (current(i) < options.readd_factor * ideal_of(i)) {
      id[i] = index.insert(pop.particles[i], pop.features[i]);
      continue;
    }
    alive[i] = 0;
    ++report.deleted;
    ++change[pop.features[i]];
  }
  // b. Too dense features: remove the highest-energy particles while each is still above ideal when its turn comes.
  for (auto it = by_energy.rbegin(); it != by_energy.rend(); ++it) {
    const size_t i = *it;
    const uint32_t f = pop.features[i];
    if (!alive[i] || change[f] >= 0 || feature_dimension(E.features[f].kind) == 0) continue;
    if (current(i) <= ideal_of(i)) continue;
    index.remove(id[i]);
    alive[i] = 0;
    ++report.deleted;
    ++change[f];
  }

  // c. Additions: add candidates first (lowest energy first), then, for sparse features, the other particles.
  //    In parallel over tiles (tile_by_parity) wide enough that two tiles of one parity never place newcomers within
  //    reach of each other: a newcomer lies within about 2 h_max of its parent (h away, then onto the feature), and
  //    pairs interact within sqrt(3) h. A tile tests its parents in energy order against the particles of earlier
  //    parities (the shared index, read only) and its own newcomers (a scratch index); each parent draws its
  //    directions from its own stream (the round's seed and its index), so the result is the same on any number of
  //    threads.
  Population out;
  for (size_t i = 0; i < n; ++i)
    if (alive[i]) {
      out.particles.push_back(pop.particles[i]);
      out.features.push_back(pop.features[i]);
    }
  const uint64_t round_seed = (uint64_t(rng()) << 32) ^ uint64_t(rng());
  float h_max = 0;
  for (size_t i = 0; i < n; ++i)
    if (alive[i]) h_max = std::max(h_max, pop.particles[i].w);
  const double tile = std::max((4.0 + double(kSupport)) * double(h_max), 8.0 * index_cell);
  tbb::enumerable_thread_specific<HostIndex> scratch(E, index_cell);
  tbb::enumerable_thread_specific<std::vector<long>> allowance(F, 0L);
  std::vector<long> budget(F, 0);
  for (size_t i = 0; i < n; ++i)
    if (alive[i] && flags[i] == 2) ++budget[pop.features[i]];
  for (size_t f = 0; f < F; ++f) budget[f] = std::max(budget[f], change[f]);
  for (int pass = 0; pass < 2; ++pass) {
    // Pass 0, the add candidates: one newcomer each at most (their feature's budget always covers that). Pass 1, the
    // other particles of a feature still short of its count. A sparse feature's newcomers may sit as high as a
    // re-inserted particle until its count is made up, min(budget, change) of them (in pass 0, change); after that
    // they only fill holes. That quota is shared among the tiles by their share of the feature's parents: a parent
    // carries a token where the running quota passes a whole number.
    std::vector<long> quota(F, 0), parents_of(F, 0);
    for (size_t f = 0; f < F; ++f) quota[f] = std::max(0L, pass == 0 ? change[f] : std::min(budget[f], change[f]));
    std::vector<uint32_t> parents;
    for (size_t i : by_energy) {
      const uint32_t f = pop.features[i];
      if (!alive[i] || feature_dimension(E.features[f].kind) == 0 || (pass == 0) != (flags[i] == 2)) continue;
      if (pass == 1 && quota[f] <= 0) continue;
      parents.push_back(uint32_t(i));
      ++parents_of[f];
    }
    const Tiles tiles = tile_by_parity(parents, tile, [&](uint32_t i) { return glm::vec3(pop.particles[i]); });
    std::vector<uint8_t> token(tiles.item.size());
    std::vector<long> seen(F, 0);
    for (size_t k = 0; k < tiles.item.size(); ++k) {
      const uint32_t f = pop.features[tiles.item[k]];
      const long q = quota[f], m = parents_of[f], a = seen[f]++;
      token[k] = uint8_t((q * (a + 1)) / m > (q * a) / m);
    }
    const bool capped = pass == 1;  // pass 1 adds only within the quota
    std::vector<std::vector<std::pair<glm::vec4, uint32_t>>> newcomers(tiles.count());
    run_by_parity(
        tiles,
        [&](size_t t) {
          HostIndex& mine = scratch.local();
          mine.clear();
          std::vector<long>& allow = allowance.local();
          for (size_t k = tiles.begin[t]; k < tiles.begin[t + 1]; ++k) allow[pop.features[tiles.item[k]]] += token[k];
          for (size_t k = tiles.begin[t]; k < tiles.begin[t + 1]; ++k) {
            const uint32_t i = tiles.item[k], f = pop.features[i];
            if (capped && allow[f] <= 0) continue;
            const double limit = (allow[f] > 0 ? options.readd_factor : options.accept_factor) * ideal_of(i);
            const glm::vec4 parent = pop.particles[i];
            SplitMix stream{round_seed ^ (uint64_t(i) * 0xd1b54a32d192ed03ull)};
            std::normal_distribution<float> n01;
            for (int attempt = 0; attempt < options.add_tries; ++attempt) {
              glm::vec3 dir(n01(stream), n01(stream), n01(stream));
              if (glm::length(dir) < 1e-6f) continue;
              dir = glm::normalize(dir);
              const auto cp = ref::cp_lookup(E, glm::vec3(parent) + parent.w * dir, f);
              if (!cp.valid || glm::length(glm::vec3(cp.value) - glm::vec3(parent)) < 0.5f * parent.w) continue;
              const glm::vec3 q(cp.value);
              if (index.energy(q, cp.value.w, f) + mine.energy(q, cp.value.w, f) >= limit) continue;
              mine.insert(cp.value, f);
              newcomers[t].push_back({cp.value, f});
              if (allow[f] > 0) --allow[f];
              break;
            }
          }
          for (size_t k = tiles.begin[t]; k < tiles.begin[t + 1]; ++k) allow[pop.features[tiles.item[k]]] = 0;
        },
        [&](size_t t) {
          for (const auto& [p, f] : newcomers[t]) {
            index.insert(p, f);
            out.particles.push_back(p);
            out.features.push_back(f);
            ++report.added;
            --budget[f];
            --change[f];
          }
        });
  }
  report.total = uint32_t(out.particles.size());
  return out;
}

void SteadyRule::after_round(uint32_t added, uint32_t deleted, uint32_t n) {
  const double net = double(added) - double(deleted), share = options_.steady_share * double(n);
  balanced_rounds_ = std::fabs(net) <= share ? balanced_rounds_ + 1 : 0;
  nets_.push_back(net);
  const auto window = size_t(std::max(options_.steady_window, 0));
  const bool on_average = window >= 2 && nets_.size() >= window &&
                          std::fabs(std::accumulate(nets_.end() - std::ptrdiff_t(window), nets_.end(), 0.0)) <=
                              double(window) * share;
  const bool negligible = double(added) + double(deleted) <= options_.negligible_share * double(n);
  steady_ = steady_ || balanced_rounds_ >= 2 || on_average || negligible;
}

RelaxResult relax(gpu::Context& ctx, const fields::ClosestPointEmbedding& E, Population start,
                  const AdvectionOptions& advection, const PopulationOptions& options,
                  const std::function<void(const RoundReport&)>& on_round,
                  const std::function<size_t(Population&)>& prune) {
  using clock = std::chrono::steady_clock;
  RelaxResult result;
  result.population = std::move(start);
  const std::vector<float> ideals = feature_ideals(E);
  std::mt19937 rng(options.seed ^ 0x9e3779b9u);
  // One copy of the embedding on the device serves every round's particle system.
  const auto gpu_embedding = std::make_shared<const fields::GpuEmbedding>(ctx, E);
  AdvectionOptions adv = advection;
  adv.max_iterations = options.iterations_per_round;
  adv.min_iterations = options.min_iterations_per_round;
  SteadyRule steady(options);
  for (int round = 1; round <= options.max_rounds; ++round) {
    RoundReport rep;
    rep.round = round;
    auto t = clock::now();
    ParticleSystem system(ctx, E, gpu_embedding, result.population.particles, result.population.features, adv);
    const auto run = system.run();
    rep.iterations = run.iterations;
    rep.converged = run.converged;
    rep.energy = run.energies.empty() ? 0.0 : run.energies.back();
    result.iterations += run.iterations;
    rep.advect_seconds = seconds_since(t);

    t = clock::now();
    const auto check = system.check_population(ideals, float(options.delete_factor), float(options.add_factor));
    rep.flagged_delete = check.delete_candidates;
    rep.flagged_add = check.add_candidates;
    for (size_t f = 0; f < ideals.size(); ++f)
      if (check.count[f] >= uint32_t(std::max(options.min_feature_particles, 1)))
        rep.max_feature_deviation =
            std::max(rep.max_feature_deviation, std::fabs(check.energy_ratio[f] / options.relaxed_energy_ratio - 1.0));
    const uint32_t n = system.size();
    result.population.particles = system.particles();
    rep.check_seconds = seconds_since(t);
    const bool balanced = rep.max_feature_deviation <= options.energy_tolerance;
    const bool settled = balanced && double(check.delete_candidates + check.add_candidates) <= options.significance * double(n);
    // A round whose add/delete step changes nothing ends the rounds too: the population is the one the last run
    // relaxed and this check measured, and another run would only repeat this round (balanced out at zero: steady).
    const bool last = settled || round == options.max_rounds || steady.steady();
    if (!last) {
      t = clock::now();
      const auto walk = system.walk_result();
      std::vector<float> energies(walk.size());
      for (size_t i = 0; i < walk.size(); ++i) energies[i] = walk[i].w;
      result.population =
          add_delete(E, result.population, energies, system.flags(), check.energy_ratio, options, rng, rep);
      if (prune) {
        rep.pruned = uint32_t(prune(result.population));
        rep.deleted += rep.pruned;
      }
      rep.host_seconds = seconds_since(t);
    }
    const bool unchanged = !last && rep.added == 0 && rep.deleted == 0;
    if (last || unchanged) {
      rep.total = n;
      result.settled = settled;
      result.steady = steady.steady() || unchanged;
    } else {
      steady.after_round(rep.added, rep.deleted, n);  // once steady, one more advection run ends the rounds
      // The next run's length at least: a small change settles locally (population.h).
      const double changed = double(rep.added) + double(rep.deleted);
      const bool small = changed <= options.small_change_share * double(n);
      adv.min_iterations = small ? std::min(options.min_iterations_per_round, options.min_iterations_after_small_change)
                                 : options.min_iterations_per_round;
    }
    result.rounds.push_back(rep);
    if (on_round) on_round(rep);
    if (last || unchanged) break;
  }
  return result;
}

namespace {

// Removes the particles with drop[i] set, keeping the others' order; returns how many went.
size_t remove_flagged(Population& population, const std::vector<uint8_t>& drop) {
  Population kept;
  for (size_t i = 0; i < population.particles.size(); ++i) {
    if (drop[i]) continue;
    kept.particles.push_back(population.particles[i]);
    kept.features.push_back(population.features[i]);
  }
  const size_t removed = population.particles.size() - kept.particles.size();
  population = std::move(kept);
  return removed;
}

}  // namespace

size_t drop_off_feature(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& E,
                        Population& population, double share) {
  const size_t n = population.particles.size();
  std::vector<uint8_t> drop(n, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const auto& feature = E.features[population.features[i]];
      if (feature.kind == fields::FeatureKind::quadruple_point) continue;
      const glm::vec4& p = population.particles[i];
      drop[i] = !(fields::feature_distance(fields, feature, glm::dvec3(glm::vec3(p))) <= share * double(p.w));
    }
  });
  return remove_flagged(population, drop);
}

size_t thin_crowded(const fields::ClosestPointEmbedding& E, Population& population, double share) {
  const size_t n = population.particles.size();
  if (n == 0 || share <= 0) return 0;
  float h_max = 0;
  for (const glm::vec4& p : population.particles) h_max = std::max(h_max, p.w);
  HostIndex kept(E, std::max(double(share) * h_max, 1e-6));
  std::vector<uint8_t> drop(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const glm::vec4& p = population.particles[i];
    const uint32_t f = population.features[i];
    drop[i] = E.features[f].kind != fields::FeatureKind::quadruple_point &&
              kept.nearest(glm::vec3(p), f, float(share * double(p.w))).has_value();
    if (!drop[i]) kept.insert(p, f);
  }
  return remove_flagged(population, drop);
}

size_t protect_junctions(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& E,
                         Population& population, double rho) {
  if (rho <= 0) return 0;
  const size_t n = population.particles.size();
  // The curves and quadruple points bounding each interface (their material sets include the interface's).
  std::vector<std::vector<uint32_t>> curves_of(E.features.size());
  std::vector<std::vector<glm::dvec3>> points_of(E.features.size());
  for (uint32_t f = 0; f < E.features.size(); ++f) {
    if (E.features[f].kind != fields::FeatureKind::interface) continue;
    const fields::MaterialSet mine = E.features[f].material_set();
    for (uint32_t c = 0; c < E.features.size(); ++c)
      if (E.features[c].kind == fields::FeatureKind::triple_curve && E.features[c].material_set().includes(mine))
        curves_of[f].push_back(c);
    for (const auto& q : E.quadruple_points)
      if (E.features[q.feature].material_set().includes(mine)) points_of[f].push_back(q.position);
  }
  // Curve particles in a host index of cells as large as the largest h among them: a point within rho h of a curve
  // lies within about h of one of its particles (they are spaced about h apart).
  float cell = 0;
  for (size_t i = 0; i < n; ++i)
    if (E.features[population.features[i]].kind == fields::FeatureKind::triple_curve)
      cell = std::max(cell, population.particles[i].w);
  if (cell <= 0) return 0;
  HostIndex curve_index(E, cell);
  for (size_t i = 0; i < n; ++i)
    if (E.features[population.features[i]].kind == fields::FeatureKind::triple_curve)
      curve_index.insert(population.particles[i], population.features[i]);

  std::vector<uint8_t> drop(n, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const uint32_t f = population.features[i];
      if (E.features[f].kind != fields::FeatureKind::interface) continue;
      const glm::dvec3 p(glm::vec3(population.particles[i]));
      const double h = double(population.particles[i].w), reach = rho * h;
      bool near = false;
      for (const glm::dvec3& q : points_of[f]) near = near || glm::length(q - p) < reach;
      for (size_t k = 0; k < curves_of[f].size() && !near; ++k) {
        // The nearest particle of the curve starts the projection (and picks the right piece of a curve in pieces).
        const uint32_t c = curves_of[f][k];
        const auto start = curve_index.nearest(glm::vec3(p), c, float(reach + h));
        if (!start) continue;
        const glm::dvec3 from(*start);
        glm::dvec3 foot;
        if (fields::project_to_feature(fields, E.features[c], p, foot, 30, 3, &from))
          near = glm::length(foot - p) < reach;
      }
      drop[i] = near;
    }
  });
  return remove_flagged(population, drop);
}

}  // namespace cpmesh::particles
