#pragma once
// The GPU particle system (seed paper Sec. 5; issue 6): per iteration, one submission that evaluates every particle's
// energy and gradient, advects the particles in their features' tangent spaces with closest point reprojection, and
// sums the energy on the GPU. The host reads back a few numbers per iteration (total energy, particles that left
// their band, the neighbour lists' drift) and applies the paper's stop rule: (E_prev - E) / E_prev < delta.
// The energy comes from Verlet neighbour lists (the default, AdvectionOptions::neighbour_skin > 0): the octree
// (Morton sort, build, moments) is walked only to list, for each particle, the particles within a skin beyond its
// energy's support, and each iteration sums over those lists until some particle has drifted far enough that a pair
// outside them could interact (drift_limit()); then the next iteration rebuilds them, or walks the octree while the
// particles move too fast for new lists to serve two iterations (AdvectionOptions). Without lists (skin 0, or the
// Barnes-Hut mode) every iteration walks the octree, re-sorted and rebuilt every rebuild_every iterations and
// refitted in between.
#include <algorithm>
#include <limits>
#include <memory>
#include <vector>

#include "fields/cp_lookup_gpu.h"
#include "octree/morton.h"
#include "octree/octree_build.h"
#include "octree/tree_walk.h"
#include "particles/particle_permute.h"
#include "primitives/reduce.h"

namespace cpmesh::particles {

struct AdvectionOptions {
  float alpha = 0.05f;      // step = -alpha h^2 grad E (the starting value: run() adapts it)
  float max_move = 0.2f;    // at most this fraction of h per iteration
  uint32_t leaf_size = 16;  // octree leaf bucket (cells below a quarter of the smallest h are leaves regardless)
  float theta = 0.0f;       // 0: exact walk (prune beyond the energy's support); > 0: Barnes-Hut opening angle
  double delta = 0.0015;    // stop when the relative energy decrease falls below this (paper)
  int max_iterations = 500;
  int min_iterations = 0;   // the stop rule is not tested before this many iterations
  // step() re-sorts the particles and rebuilds the octree's topology every this many iterations and only refits its
  // moments (boxes, centres, counts) in between: the walk prunes by the refitted boxes, so it stays exact, and
  // particles move at most max_move h per iteration, so the boxes loosen little. 1: rebuild every iteration. The
  // neighbour lists' builds (below) follow the same schedule: they refit the octree in between.
  int rebuild_every = 8;
  // Verlet neighbour lists (exact mode only, theta = 0): particle i's list holds the j within SUPPORT min(h_i, h_j)
  // (1 + skin) (SUPPORT = 2 cos(pi/6): the energy's support, widened by the skin); 0: walk every iteration.
  // They stay exact while every particle has moved less than drift_limit() times its h since they were built: with
  // a the one of a pair with the smaller h (m = h_a) and b the other, a pair left out was r0 >= SUPPORT m (1 + s)
  // apart; after moves of at most delta h_a and delta h_b, with h Lipschitz with constant g along the surfaces (so
  // h_b <= m + g r0, and h_a grows by at most g delta m), it is still at least SUPPORT m (1 + g delta) apart, beyond
  // the support, when delta <= SUPPORT s / (2 + SUPPORT g (2 + s)).
  // Lists pay for their build (a walk with the wider reach, about 1.4 plain walks on lavapipe, plus a refit) only
  // when they serve two steps or more (a step over them costs about a third of a walk there), that is when no
  // particle moves more than drift_limit() h in a step. So lists are built only after a step that moved no particle
  // farther than that: a walked step measures its largest move (neighbour_drift.comp from the positions before it),
  // expired lists give their mean per step. A system's first step walks (nothing measured yet); where some particles
  // move fast (all of them just after seeding, the new ones after an add/delete round for about three steps, thin
  // layers that do not settle) the steps walk until they slow down. (Before: lists were built regardless and, when
  // they served one step, the next 4 to 32 steps walked; the 128^3 wedge ball took 15 walks and 12 builds in its
  // 50 steps, now 13 and 11; 11 walks once the population check summed over the lists that still held.)
  // A list buffer longer than the device allows (maxStorageBufferRange) or than kMaxListEntries per particle turns
  // the lists off for that system (uses_lists() false): it walks the octree every step instead.
  // Measured on lavapipe, 128^3 wedge ball at --max-size 2 (13 k particles, 40 steps from the seeding), before the
  // texel buffers (which halved walks and steps alike): 91 ms a step walking the octree, 66 / 64 / 63 ms with skins
  // 0.3 / 0.5 / 0.8 (13 / 9 / 8 builds, 41 / 54 / 78 entries per particle); identical energies. The whole advection
  // (three rounds, 50 steps): 5.5-5.6 -> 4.7-4.9 s; 64^3 1.07-1.13 -> 0.93-0.96 s. With the texel buffers (two
  // rounds, 40 steps): 2.27-2.35 s walking, 1.96-1.99 s with lists.
  float neighbour_skin = 0.5f;
  float neighbour_grading = 1.0f;  // g above: the sizing field's grading (SizingOptions::grading, default 0.5) or more
  float drift_limit() const {
    constexpr float kSupport = 1.7320508f;
    return kSupport * neighbour_skin / (2.0f + kSupport * neighbour_grading * (2.0f + neighbour_skin));
  }
};

// The options with neighbour_grading at least the sizing field's grading (SizingOptions::grading), so the lists'
// drift bound holds for the h the particles read.
inline AdvectionOptions with_sizing_grading(AdvectionOptions a, double grading) {
  a.neighbour_grading = std::max(a.neighbour_grading, float(grading));
  return a;
}

struct IterationStats {
  double energy = 0;   // total energy before the step
  uint32_t lost = 0;   // particles whose step left their feature's band (they stayed put)
};

class ParticleSystem {
 public:
  // particles: xyz local position on its feature, w sizing h; features: index into embedding.features.
  ParticleSystem(gpu::Context& ctx, const fields::ClosestPointEmbedding& embedding, const std::vector<glm::vec4>& particles,
                 const std::vector<uint32_t>& features, const AdvectionOptions& options = {});
  // The same with the embedding already on the device (gpu_embedding of `embedding`), e.g. shared by the systems of
  // successive add/delete rounds: building and uploading it took 0.17-0.19 s per round at 128^3.
  ParticleSystem(gpu::Context& ctx, const fields::ClosestPointEmbedding& embedding,
                 std::shared_ptr<const fields::GpuEmbedding> gpu_embedding, const std::vector<glm::vec4>& particles,
                 const std::vector<uint32_t>& features, const AdvectionOptions& options = {});

  IterationStats step();  // one iteration, one submission, with the current step factor
  // run(): iterations until the stop rule. The step factor halves whenever the total energy rose (down to 1/64 of
  // the start) and grows by 10% per decreasing step back up to the start, so a step can never make the energy grow
  // for long; the move is also clamped to max_move h.
  struct RunResult {
    int iterations = 0;
    bool converged = false;
    std::vector<double> energies;
  };
  RunResult run();

  std::vector<glm::vec4> particles() const { return in_caller_order(particles_); }
  // Energy and gradient of every particle at the current positions (a walk without a step).
  std::vector<glm::vec4> energies();
  uint32_t size() const { return n_; }
  // Pairs evaluated by the last energy evaluation, walk or neighbour lists (a lumped node counts its particles), read
  // back from the GPU.
  uint64_t last_pair_count() const;
  uint64_t last_node_visits() const;  // by the last walk (0 when the last step summed over the neighbour lists)
  float alpha() const { return alpha_; }
  bool uses_lists() const {
    return options_.neighbour_skin > 0.0f && options_.theta <= 0.0f && !lists_too_long_ && n_ > 0;
  }
  static constexpr uint32_t kMaxListEntries = 256;  // per particle (uses_lists() above)
  int list_builds() const { return list_builds_; }      // neighbour list builds so far
  uint32_t list_capacity() const { return list_capacity_; }  // entries per particle of the list buffer
  // Largest move / h since the lists were built, after the last step() that summed over them.
  float drift() const { return drift_; }
  // Largest move / h in one step: of the last walked step, or the mean per step of the last lists (what decides the
  // next build, below); infinite before any step.
  float last_move() const { return last_move_; }

  // Population check (seed paper Sec. 6.2, step one; particles/population.h): the energies at the current positions
  // (over the neighbour lists while they hold, else by a walk of the octree, re-sorted only on its schedule), then
  // flags add/delete candidates on the GPU (shaders/population_flags.comp) against each feature's ideal energy.
  // Reads back 2 + 2 x features numbers; flags() and walk_result() read the rest only when needed.
  struct PopulationCheck {
    uint32_t delete_candidates = 0, add_candidates = 0;
    std::vector<double> energy_ratio;  // per feature: mean E / ideal (0 where it has no particle or no ideal)
    std::vector<uint32_t> count;       // per feature: particles counted
  };
  PopulationCheck check_population(const std::vector<float>& ideals, float delete_factor, float add_factor);
  // Of the last check: 0, 1 delete, 2 add. Read them before the next step() or energies(), which may re-sort the
  // slots.
  std::vector<uint32_t> flags() const { return in_caller_order(flags_); }
  // (gradient, E) of the last energy evaluation (a step's, the check's), by a walk or over the lists.
  std::vector<glm::vec4> walk_result() const { return in_caller_order(walk_result_); }

 private:
  void record_walk(gpu::Sequence& seq, bool rebuild);
  // The lists no longer serve (expired, or the slots moved): their mean move per step becomes last_move_.
  void discard_lists();
  // Every particle's energy and gradient into walk_result_: over the neighbour lists (lists: lists_hold()) or by a
  // walk (the octree re-sorted when rebuild_due()).
  void record_energies(gpu::Sequence& seq, bool lists);
  bool lists_hold() const { return uses_lists() && lists_valid_ && drift_ <= options_.drift_limit(); }
  void record_tree(gpu::Sequence& seq, bool rebuild);  // sort and build (rebuild) or not, then the moments
  bool rebuild_due() const {  // the octree's topology is rebuild_every steps old (or was never built)
    return steps_since_build_ < 0 || steps_since_build_ >= std::max(options_.rebuild_every, 1);
  }
  void build_lists();  // its own submission(s): tree, lists (grown until they fit), anchors
  // A per-slot buffer read back with element i for the caller's particle i (slots are in Morton order).
  template <class T>
  std::vector<T> in_caller_order(const gpu::Buffer<T>& buffer) const {
    const std::vector<T> by_slot = buffer.download(0, n_);
    if (ids_host_.size() != n_) ids_host_ = ids_.download(0, n_);  // once per octree rebuild
    const std::vector<uint32_t>& ids = ids_host_;
    std::vector<T> out(n_);
    for (uint32_t q = 0; q < n_; ++q) out[ids[q]] = by_slot[q];
    return out;
  }
  gpu::Context* ctx_;
  AdvectionOptions options_;
  float alpha_;
  uint32_t n_;
  std::shared_ptr<const fields::GpuEmbedding> embedding_;
  octree::MortonBox box_;
  uint32_t max_level_ = 21;     // octree depth: cells down to a quarter of the smallest h (octree_levels)
  int steps_since_build_ = -1;  // step() iterations since the octree topology was built (-1: never)
  octree::MortonSort sort_;
  octree::OctreeBuild build_;
  octree::OctreeMoments moments_;
  octree::TreeWalk walk_;
  ParticlePermute permute_;
  gpu::Reduce reduce_;
  gpu::Kernel advect_, population_flags_, neighbour_energy_, neighbour_drift_;
  gpu::Buffer<glm::vec4> particles_, particles_spare_, walk_result_;
  octree::NodeMoments node_moments_;
  gpu::Buffer<uint32_t> features_, features_spare_, ids_, ids_spare_;  // ids_: the caller's index of each slot
  mutable std::vector<uint32_t> ids_host_;  // ids_ as last read back; emptied when a rebuild reorders the slots
  gpu::Buffer<uint32_t> feature_kinds_, order_, counts_, visits_, lost_, flags_;
  gpu::Buffer<uint64_t> keys_;
  gpu::Buffer<glm::uvec4> masks_, masks_spare_;  // per slot: its feature's material mask (octree::particle_masks)
  gpu::Buffer<glm::uvec4> nodes_;
  gpu::Buffer<glm::uvec2> level_info_;
  gpu::Buffer<float> energy_, readback_;
  // Neighbour lists: entries (n x capacity, allocated at the first build), lengths, anchors (the positions at the
  // build, or before a walked step's advection, which measures its move from them), and two readback words (longest
  // list, drift bits).
  gpu::Buffer<uint32_t> lists_, list_lengths_, longest_, drift_bits_;
  gpu::Buffer<glm::vec4> anchors_;
  uint32_t list_capacity_ = 0;
  bool lists_valid_ = false;  // built, and no re-sort since (the lists index particle slots)
  bool lists_too_long_ = false;  // a build found a list longer than the buffer may be: walk instead (above)
  float drift_ = 0.0f;
  int list_builds_ = 0;
  int list_steps_ = 0;        // steps served by the current lists
  bool last_step_listed_ = false;  // the last energy evaluation summed over the lists (no walk)
  // The largest move / h of one step, measured by the last walked step or averaged over the last lists' steps; none
  // yet: the first step walks.
  float last_move_ = std::numeric_limits<float>::infinity();
};

}  // namespace cpmesh::particles
