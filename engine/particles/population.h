#pragma once
// Particle population (seed paper Sec. 6; issue 7): the ideal energy, curvature-aware seeding, and add/delete rounds
// between advection runs.
//
// Seeding (Sec. 6.1): quadruple points exactly; then, curves before interfaces, the closest points of the grid
// points next to each feature (the embedding's blocks whose cell touches it), plus C / h random points per such cell
// where h < 1 voxel (projected with the embedding); every seed is tested against a serial host index of the seeds
// kept so far and kept only if its energy is below seed_energy_factor x ideal, so flat regions are not oversampled.
// A curve seeded this way is sampled at about h along its length: a seed closer than ~0.6 h to a kept one is refused.
//
// Add/delete (Sec. 6.2), after each advection run:
//   1. GPU (ParticleSystem::check_population): flag particles with E > delete_factor x ideal (delete candidates) and
//      E < add_factor x ideal (add candidates), count them, and sum E / ideal per feature. The host reads back only
//      these counts and sums; the population is settled when few particles are flagged (significance) and every
//      feature's mean E / ideal is within energy_tolerance of 1.
//   2. Otherwise the host reads the population back once and, inserting one particle at a time into a host index
//      (so two neighbours never both decide to leave or stay; the additions run in parallel over tiles of one
//      parity at a time, far enough apart that no two tiles' newcomers meet, with the same result on any thread count):
//      a. removes the delete candidates and re-inserts each, lowest energy first, keeping it only if its energy is
//         below readd_factor x ideal (the paper's 4x);
//      b. corrects each feature's count towards the density its mean energy asks for: a feature whose mean E / ideal
//         says it is denser than a hexagonal packing at h loses its highest-energy particles (each only if its
//         energy is still above ideal when its turn comes), a sparser one gains particles (step c);
//      c. for add candidates (and the lowest-energy particles of a sparse feature), tries a new particle h away in a
//         random direction, put on the feature by the embedding, kept only if its energy is below accept_factor x
//         ideal (a hole) or, while a sparse feature's count is below what it needs, readd_factor x ideal.
//   A run lasts min_iterations_per_round at least, as the energies right after a change are not yet relaxed, and the
//   relative stop rule sees nothing of a few local changes; after an add/delete step that changed at most
//   small_change_share of the particles, min_iterations_after_small_change (the stop rule may still run it longer).
//   Rounds end when the population is settled, when a round's add/delete step changed nothing (the population is
//   then the one the last run relaxed: no further run), or when adds and deletes have balanced out two rounds
//   running (steady: graded sizing keeps a churn of local adds and deletes, as the pair energy scales with the
//   smaller h), or on average over steady_window rounds (a churn that swings the count up and down), or after one
//   round that changed a negligible share (negligible_share); every ending is after an advection run of the final
//   population.
//      The changed population is uploaded once per round.
// The paper's rules (a) and (c) only repair local holes and clumps: a population that is evenly too dense or too
// sparse has every particle's energy between the thresholds, so (b) is what brings the count to the sizing field's.
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <vector>

#include "fields/closest_point_embedding.h"
#include "particles/particle_system.h"

namespace cpmesh::particles {

// Cotangent energy of a pair (Eq. 1) at d = r / (sqrt(3) min(h_i, h_j)); float arithmetic as the tree walk's.
float pair_energy(float d);
// Energy of one particle in an infinite lattice of spacing s (in units of h): hexagonal for dim 2, a row for dim 1.
double lattice_energy(double spacing, int dim);
// The ideal energy of a particle of a feature: its lattice energy at spacing h (0 for quadruple points).
double ideal_energy(fields::FeatureKind kind);
// Density of an even population whose energies average energy_ratio x ideal, relative to the ideal one:
// (h / s)^dim with lattice_energy(s) = energy_ratio x ideal. Above 1: denser than ideal. An energy of 0 says only
// that s >= sqrt(3) h, so the ratio is capped there (1/3 for dim 2).
double density_ratio(double energy_ratio, int dim);
int feature_dimension(fields::FeatureKind kind);

struct PopulationOptions {
  double random_seed_constant = 2.0;  // C: random seeds per grid point where h < random_seed_below (paper: 2)
  double random_seed_below = 1.0;     // voxels: sizing below which random seeds are added (paper: 1)
  double seed_energy_factor = 1.5;    // a seed is kept if its energy is below this x ideal. A random sequential
                                      // packing is sparser than a relaxed one: at 1.0 the seeds were 80-88% of the
                                      // settled count (wedge ball 64^3 and 128^3, sphere), and the add rounds that
                                      // made up the rest were most of the advection; at 1.5, 98-107%, and 128^3 at
                                      // h <= 2 settled in 3 rounds instead of 7
  double delete_factor = 2.0;         // delete candidate: E above this x ideal
  double add_factor = 0.5;            // add candidate: E below this x ideal
  double readd_factor = 4.0;          // a delete candidate is re-inserted if its energy is below this x ideal (paper)
  double accept_factor = 1.0;         // a new particle filling a hole is kept if its energy is below this x ideal
                                      // (raising a sparse feature's count: below readd_factor x ideal)
  double relaxed_energy_ratio = 1.08; // mean E / ideal of a relaxed population at the ideal density: above 1, as
                                      // a relaxed population is never a perfect lattice (jitter, the defects a
                                      // closed surface needs) and the energy is convex. Calibrated on the
                                      // sphere (population_test.cpp): at 1.0 populations settled 4-5% below the
                                      // hexagonal count, at 1.15 up to 5% above it (434 of 412.7)
  double energy_tolerance = 0.05;     // settled when each feature's mean E / ideal is within this of the above ...
  double significance = 0.1;          // ... and at most this share of the particles is flagged
  double steady_share = 0.01;         // steady: |added - deleted| at most this share of n two rounds running, or
  int steady_window = 4;              // |sum of (added - deleted)| over this many rounds at most this many times
                                      // that share of n (0 or 1: no such window)
  double negligible_share = 0.001;    // ... or, at once, added + deleted at most this share of n: so few changes
                                      // settle in the next run, and another round would change as little
  int max_rounds = 20;                // add/delete rounds at most
  int iterations_per_round = 60;      // advection iterations per round at most (graded sizing rarely meets the stop
                                      // rule; 150 took 3x the time for the same quality on the wedge ball)
  int min_iterations_per_round = 30;  // ... and at least (energies right after a change are not yet relaxed)
  int min_iterations_after_small_change = 10;  // ... but this many after an add/delete step that changed at most
  double small_change_share = 0.02;            // this share of the particles: the new particles fill holes and
                                               // settle locally. Measured against 30 (surfaces, wedge ball):
                                               // 128^3 at h <= 2 90 -> 50 iterations, radius ratio mean / min
                                               // 0.969 / 0.731 -> 0.964 / 0.704; 64^3 seeds 1, 2: 330 -> 213 and
                                               // 300 -> 310 iterations, 0.952 / 0.701 -> 0.950 / 0.708 and
                                               // 0.955 / 0.700 -> 0.951 / 0.639; the 48^3 asset (seeds 1-3) the same
                                               // meshes but for seed 1 (330 -> 311 iterations, 0.945 / 0.683 ->
                                               // 0.944 / 0.683)
  double count_gain = 0.5;            // share of a feature's count error corrected per round (damps overshoot)
  int min_feature_particles = 20;     // features with fewer particles get no count correction (their mean
                                      // energy is too noisy) and do not hold back settling
  int add_tries = 8;                  // random directions tried per add candidate
  uint32_t seed = 1;                  // random seed: same seed, same population
};

struct Population {
  std::vector<glm::vec4> particles;  // local xyz, h in w
  std::vector<uint32_t> features;    // embedding feature index
};

// Exact energies of host-side particles: a uniform hash grid (the energy has compact support, sqrt(3) h, so there is
// no far field to lump as in a Barnes-Hut tree). Particles are inserted and removed one at a time.
class HostIndex {
 public:
  HostIndex(const fields::ClosestPointEmbedding& embedding, double cell);
  uint32_t insert(const glm::vec4& particle, uint32_t feature);
  void remove(uint32_t id);
  // Energy of a particle at p with sizing h on `feature` against every live particle except `skip`, with the tree
  // walk's interaction rule (j's materials include i's).
  double energy(const glm::vec3& p, float h, uint32_t feature, uint32_t skip = ~0u) const;
  // The live particle of exactly `feature` nearest to p within `radius` (its position), or nothing.
  std::optional<glm::vec3> nearest(const glm::vec3& p, uint32_t feature, float radius) const;
  const std::vector<fields::MaterialSet>& masks() const { return masks_; }
  size_t size() const { return live_; }
  // Empties the index, keeping its memory (a scratch index reused tile after tile).
  void clear();

 private:
  struct Entry;
  glm::ivec3 cell_of(const glm::vec3& p) const;
  static uint64_t key(const glm::ivec3& c);
  // Calls fn(id, entry) for every live particle in the cells covering the ball of `radius` around p, cell by cell,
  // in insertion order within a cell.
  template <class Fn>
  void for_each_near(const glm::vec3& p, float radius, Fn&& fn) const {
    const glm::ivec3 lo = cell_of(p - radius), hi = cell_of(p + radius);
    for (int z = lo.z; z <= hi.z; ++z)
      for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
          const size_t slot = find(key({x, y, z}));
          if (slot == kNoSlot) continue;
          for (uint32_t j = table_[slot].head; j != kNone; j = entries_[j].next)
            if (entries_[j].live) fn(j, entries_[j]);
        }
  }
  double cell_;
  float h_max_ = 0;
  size_t live_ = 0;
  std::vector<fields::MaterialSet> masks_;
  struct Entry {
    glm::vec4 particle;
    uint32_t feature;
    bool live;
    uint32_t next;  // the next entry of its cell (kNone: the last)
  };
  std::vector<Entry> entries_;
  // The cells: an open-addressing table (linear probing, a power of two, at most half full) of lists threaded
  // through the entries. No allocation per cell, and a removed entry is only marked: a hash map of vectors spent
  // most of the seeding and the add/delete steps in allocations and erases at a million particles.
  static constexpr uint32_t kNone = ~0u;
  static constexpr size_t kNoSlot = ~size_t(0);
  struct Cell {
    uint64_t key = 0;
    uint32_t head = kNone, tail = kNone;  // head == kNone: an empty slot
  };
  std::vector<Cell> table_;
  std::vector<size_t> used_slots_;  // the slots holding a cell, for clear()
  size_t cells_used_ = 0;
  size_t find(uint64_t key) const;  // the slot holding key, or kNoSlot
};

struct SeedStats {
  size_t candidates = 0, grid_candidates = 0, random_candidates = 0, kept = 0;
};

// Seeding (Sec. 6.1). grid_only: no random seeds and no energy test (BioMesh3D's seeding, for comparison).
Population seed_population(const fields::ClosestPointEmbedding& embedding, const PopulationOptions& options,
                           SeedStats* stats = nullptr, bool grid_only = false);

// The feature ideal energies and flag thresholds as the GPU check takes them.
std::vector<float> feature_ideals(const fields::ClosestPointEmbedding& embedding);

struct RoundReport {
  int round = 0;
  int iterations = 0;        // advection iterations of the run before the check
  bool converged = false;    // that run met the stop rule
  double energy = 0;         // total energy at the end of the run
  uint32_t flagged_delete = 0, flagged_add = 0;
  uint32_t added = 0, deleted = 0, total = 0;  // total: after the round's changes
  uint32_t pruned = 0;  // removed by relax's prune after the add/delete step (counted in deleted too)
  double max_feature_deviation = 0;  // max over features of |mean E / (ideal x relaxed_energy_ratio) - 1|
  double advect_seconds = 0, check_seconds = 0, host_seconds = 0;
};

// One host add/delete step (2a-2c above) on a read-back population with its walk energies and GPU flags
// (1: delete candidate, 2: add candidate). Returns the new population; counts in report.
Population add_delete(const fields::ClosestPointEmbedding& embedding, const Population& population,
                      const std::vector<float>& energies, const std::vector<uint32_t>& flags,
                      const std::vector<double>& feature_energy_ratio, const PopulationOptions& options,
                      std::mt19937& rng, RoundReport& report);

// The steady rule (above), fed each add/delete step's counts: steady once adds and deletes have balanced out
// (|added - deleted| at most steady_share of n) two rounds running, or on average over the last steady_window
// rounds (|sum of (added - deleted)| at most steady_window x steady_share x n: a churn that swings the count up and
// down; on the 32^3 shells a tenth of the particles were deleted and re-added every round, and the rounds ran to
// max_rounds, about 3x the time, for meshes of about the same quality over three seeds), or once a round changed at
// most negligible_share of n (a few holes filled). It stays steady; relax then ends after one more advection run.
class SteadyRule {
 public:
  explicit SteadyRule(const PopulationOptions& options) : options_(options) {}
  void after_round(uint32_t added, uint32_t deleted, uint32_t n);
  bool steady() const { return steady_; }

 private:
  PopulationOptions options_;
  int balanced_rounds_ = 0;
  std::vector<double> nets_;  // added - deleted, per round
  bool steady_ = false;
};

struct RelaxResult {
  Population population;
  std::vector<RoundReport> rounds;
  bool settled = false;  // few flags and every feature's mean energy on target
  bool steady = false;   // ended because adds and deletes balanced out (graded sizing keeps some churn) or a round
                         // changed nothing
  int iterations = 0;
};

// Advection runs and add/delete rounds until the population is settled (or max_rounds). on_round is called after
// every round (progress). prune, where given, runs after every add/delete step and returns how many particles it
// removed: the mesher drops the particles that the lookup took off their feature there (drop_off_feature), so that
// the next run relaxes the others without them and the add steps fill the gaps they leave (docs/design.md, "Particles
// off their feature").
RelaxResult relax(gpu::Context& ctx, const fields::ClosestPointEmbedding& embedding, Population start,
                  const AdvectionOptions& advection, const PopulationOptions& options,
                  const std::function<void(const RoundReport&)>& on_round = {},
                  const std::function<size_t(Population&)>& prune = {});

// Junction protection, for meshing: removes every interface particle closer than rho x its h to a triple curve or
// quadruple point that bounds its interface (curves: the closest point on the curve of the smooth fields, by the
// embedding's Newton projection from the nearest particle of that curve; quadruple points: their positions). The
// particle system keeps interface particles about h from curve particles, but between two curve particles nothing
// stops them from creeping up to the curve itself (they feel only curve particles, not the
// interfaces across the curve), and a particle a fraction of h from a curve makes the restricted Delaunay
// triangles there slivers or gives triangles that span the curve (wrong faces, non-manifold interfaces). A band
// free of interface particles around every curve is the protecting-ball condition of Cheng, Dey and Ramos
// (Delaunay refinement for piecewise smooth complexes) in its simplest form. Returns the count removed.
size_t protect_junctions(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding,
                         Population& population, double rho);

// Removes every particle (but quadruple points) that lies farther than `share` x its h from its feature of the smooth
// fields (fields::feature_distance: off the constraints, or inside another material). Advection and the add rounds
// put particles where the embedding's closest point lookup says, and near thin parts that lookup can answer a place
// well off the feature; a particle left there pulls its interface into a spike through a neighbouring material (the
// 160^3 head proxy: an interface 1/2 particle 3.4 voxels from material 2, on the 0/1 interface, which made a
// 0.005-degree tet) or sits inside a material as a vertex of no interface. Returns the count removed; the order of
// the rest is kept.
size_t drop_off_feature(const fields::IndicatorFields& fields, const fields::ClosestPointEmbedding& embedding,
                        Population& population, double share);

// Removes every particle (but quadruple points) closer than `share` x its h to an earlier particle of the same
// feature, keeping the first of each crowded group in population order. The energy keeps neighbours about h apart,
// but a feature too small for the particles it holds (a 2-voxel island with 6 particles, a thin tube's lumen) packs
// them a few hundredths of a voxel apart, where the adds and deletes stop (a feature keeps min_feature_particles), and
// two samples that close on one surface make near-flat tets between them (islands-48: a 0.3 h pair gave the volume's
// worst tet). Returns the count removed; the order of the rest is kept.
size_t thin_crowded(const fields::ClosestPointEmbedding& embedding, Population& population, double share);

}  // namespace cpmesh::particles
