#include "particles/particle_system.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "cpmesh/shaders.h"

namespace cpmesh::particles {

namespace {

std::vector<uint32_t> identity(size_t n) {
  std::vector<uint32_t> v(n);
  std::iota(v.begin(), v.end(), 0u);
  return v;
}

std::vector<uint32_t> feature_kinds(const fields::ClosestPointEmbedding& E) {
  std::vector<uint32_t> kinds;
  for (const auto& f : E.features) kinds.push_back(uint32_t(f.kind));
  return kinds;
}

}  // namespace

ParticleSystem::ParticleSystem(gpu::Context& ctx, const fields::ClosestPointEmbedding& E,
                               const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                               const AdvectionOptions& options)
    : ParticleSystem(ctx, E, std::make_shared<const fields::GpuEmbedding>(ctx, E), particles, features, options) {}

ParticleSystem::ParticleSystem(gpu::Context& ctx, const fields::ClosestPointEmbedding& E,
                               std::shared_ptr<const fields::GpuEmbedding> gpu_embedding,
                               const std::vector<glm::vec4>& particles, const std::vector<uint32_t>& features,
                               const AdvectionOptions& options)
    : ctx_(&ctx),
      options_(options),
      alpha_(options.alpha),
      n_(uint32_t(particles.size())),
      embedding_(std::move(gpu_embedding)),
      box_(octree::MortonBox::around(glm::vec3(0.0f), glm::vec3(glm::dvec3(E.grid.dims) * E.grid.spacing))),
      sort_(ctx),
      build_(ctx),
      moments_(ctx, fields::needs_exact_sets(fields::material_sets(E.features))),
      walk_(ctx, fields::needs_exact_sets(fields::material_sets(E.features))),
      permute_(ctx),
      reduce_(ctx),
      advect_(ctx, shaders::advect, embedding_->spec_constants()),
      population_flags_(ctx, shaders::population_flags),
      neighbour_energy_(ctx, shaders::neighbour_energy),
      neighbour_drift_(ctx, shaders::neighbour_drift),
      particles_(ctx, particles, "particles"),
      particles_spare_(ctx, n_, "particles (permuted)"),
      walk_result_(ctx, n_, "walk result"),
      node_moments_(ctx, octree::OctreeBuild::node_capacity(n_, options.leaf_size)),
      features_(ctx, features, "particle features"),
      features_spare_(ctx, n_, "particle features (permuted)"),
      ids_(ctx, identity(n_), "particle ids"),
      ids_spare_(ctx, n_, "particle ids (permuted)"),
      feature_kinds_(ctx, feature_kinds(E), "feature kinds"),
      order_(ctx, n_, "morton order"),
      counts_(ctx, n_, "walk counts"),
      visits_(ctx, n_, "walk visits"),
      lost_(ctx, 1, "lost particles", gpu::MemoryUse::readback),
      flags_(ctx, n_, "population flags"),
      keys_(ctx, n_, "morton keys"),
      masks_(ctx, octree::particle_masks(features, fields::material_sets(E.features)), "particle masks"),
      masks_spare_(ctx, n_, "particle masks (permuted)"),
      nodes_(ctx, octree::OctreeBuild::node_capacity(n_, options.leaf_size), "octree nodes"),
      level_info_(ctx, 22, "octree levels"),
      energy_(ctx, n_, "particle energy"),
      readback_(ctx, 1, "total energy", gpu::MemoryUse::readback) {
  if (uses_lists()) {
    if (!(options.neighbour_grading >= 0.0f)) throw std::invalid_argument("neighbour lists: the grading must be >= 0");
    list_lengths_ = gpu::Buffer<uint32_t>(ctx, n_, "neighbour list lengths");
    longest_ = gpu::Buffer<uint32_t>(ctx, 1, "longest neighbour list", gpu::MemoryUse::readback);
    drift_bits_ = gpu::Buffer<uint32_t>(ctx, 1, "neighbour drift", gpu::MemoryUse::readback);
    anchors_ = gpu::Buffer<glm::vec4>(ctx, n_, "neighbour list anchors");
  }
  if (features.size() != particles.size()) throw std::invalid_argument("one feature per particle");
  // Octree depth: particles keep about h apart, so cells smaller than a quarter of the smallest h (of the sizing field
  // and of these particles) split nothing useful; stopping there saves most of the 21 levels' dispatches.
  float h_min = std::numeric_limits<float>::infinity();
  for (const auto& f : E.fine)
    if (f.w > 0) h_min = std::min(h_min, f.w);
  for (const auto& p : particles)
    if (p.w > 0) h_min = std::min(h_min, p.w);
  const glm::dvec3 size = glm::dvec3(E.grid.dims) * E.grid.spacing;
  const double extent = std::max({size.x, size.y, size.z});
  if (std::isfinite(h_min))
    max_level_ = uint32_t(std::clamp(int(std::ceil(std::log2(extent / (0.25 * double(h_min))))), 1, 21));
}

void ParticleSystem::record_tree(gpu::Sequence& seq, bool rebuild) {
  if (rebuild) {
    sort_.record(seq, particles_, box_, keys_, order_, n_, max_level_);
    permute_.record(seq, order_, particles_, features_, ids_, masks_, particles_spare_, features_spare_, ids_spare_,
                    masks_spare_, n_);
    seq.barrier();
    std::swap(particles_, particles_spare_);
    std::swap(features_, features_spare_);
    std::swap(ids_, ids_spare_);
    std::swap(masks_, masks_spare_);
    ids_host_.clear();
    discard_lists();  // the slots moved
    build_.record(seq, keys_, n_, options_.leaf_size, nodes_, level_info_, max_level_);
    steps_since_build_ = 0;
  }
  moments_.record(seq, nodes_, level_info_, order_, particles_, masks_, node_moments_, n_, max_level_);
}

void ParticleSystem::discard_lists() {
  if (lists_valid_) last_move_ = drift_ / float(std::max(list_steps_, 1));
  lists_valid_ = false;
}

void ParticleSystem::record_energies(gpu::Sequence& seq, bool lists) {
  last_step_listed_ = lists;
  if (!lists) {
    record_walk(seq, rebuild_due());
    return;
  }
  const struct {
    uint32_t n, capacity;
  } push{n_, list_capacity_};
  seq.dispatch(neighbour_energy_, {particles_, lists_, list_lengths_, walk_result_, counts_}, push, n_).barrier();
}

void ParticleSystem::record_walk(gpu::Sequence& seq, bool rebuild) {
  record_tree(seq, rebuild);
  last_step_listed_ = false;
  walk_.record(seq, nodes_, node_moments_, order_, particles_, masks_, walk_result_, counts_, visits_, n_, ~0u,
               options_.theta);
  seq.barrier();
}

void ParticleSystem::build_lists() {
  // The first capacity is a guess (a relaxed surface sampling has about 18 particles within the support, 40 within
  // a skin of 0.5); the walk reports the longest list, and the lists are walked again into a buffer a quarter longer
  // than that whenever it did not fit. Longer than the limit: walk every step instead (particle_system.h).
  const uint64_t limit = std::min<uint64_t>(
      kMaxListEntries, ctx_->info().max_storage_buffer_range / sizeof(uint32_t) / std::max<uint32_t>(n_, 1));
  const float reach = 1.0f + options_.neighbour_skin;
  if (list_capacity_ == 0)
    list_capacity_ = uint32_t(std::min<uint64_t>(limit, std::max(8u, uint32_t(std::ceil(24.0f * reach * reach)))));
  if (list_capacity_ == 0) {  // not even one entry per particle fits the device's buffer range
    lists_too_long_ = true;
    return;
  }
  bool fresh_tree = true;
  for (;;) {
    if (lists_.size() < size_t(n_) * list_capacity_) {
      lists_ = gpu::Buffer<uint32_t>();  // release before allocating the larger one
      lists_ = gpu::Buffer<uint32_t>(*ctx_, size_t(n_) * list_capacity_, "neighbour lists");
    }
    gpu::Sequence seq(*ctx_);
    seq.fill(longest_, 0).barrier();
    // The octree is re-sorted and rebuilt on the walk's schedule (rebuild_every) and refitted in between: refitted
    // boxes keep the walk exact, and without a re-sort the particle slots, which the lists index, stay put.
    if (fresh_tree) record_tree(seq, rebuild_due());
    seq.barrier();
    walk_.record_lists(seq, nodes_, node_moments_, order_, particles_, masks_, lists_, list_lengths_, visits_,
                       longest_, n_, options_.neighbour_skin, list_capacity_);
    seq.copy(particles_, anchors_, uint64_t(n_) * sizeof(glm::vec4)).barrier();
    seq.submit_and_wait();
    fresh_tree = false;
    const uint32_t longest = longest_.read(0);
    if (longest <= list_capacity_) break;
    if (longest > limit) {
      lists_too_long_ = true;
      lists_ = gpu::Buffer<uint32_t>();
      return;
    }
    list_capacity_ = uint32_t(std::min<uint64_t>(limit, longest + longest / 4 + 1));
  }
  lists_valid_ = true;
  drift_ = 0.0f;
  list_steps_ = 0;
  ++list_builds_;
}

std::vector<glm::vec4> ParticleSystem::energies() {
  gpu::Sequence seq(*ctx_);
  record_walk(seq, true);
  seq.submit_and_wait();
  return in_caller_order(walk_result_);
}

IterationStats ParticleSystem::step() {
  bool lists = false;
  if (uses_lists()) {
    const float limit = options_.drift_limit();
    if (lists_hold()) {
      lists = true;
    } else {
      discard_lists();
      // New lists only where they will serve two steps or more (particle_system.h): the last step moved no
      // particle farther than the bound.
      if (last_move_ <= limit) {
        build_lists();
        lists = uses_lists();  // (the build may have found them too long)
      }
    }
  }
  if (lists) ++list_steps_;
  const bool measure = uses_lists();  // each step's drift: from the lists' anchors, or this walked step's move
  gpu::Sequence seq(*ctx_);
  seq.fill(lost_, 0);
  if (measure) seq.fill(drift_bits_, 0);
  seq.barrier();
  record_energies(seq, lists);
  if (!lists && measure) seq.copy(particles_, anchors_, uint64_t(n_) * sizeof(glm::vec4)).barrier();
  ++steps_since_build_;
  const auto& e = *embedding_;
  const struct {
    glm::ivec4 dims_sub;
    glm::vec4 spacing;
    uint32_t table_mask, chunk_blocks, n;
    float alpha, max_move;
  } push{glm::ivec4(e.dims, e.sub), glm::vec4(e.spacing, 0.0f), e.table_mask, e.chunk_blocks, n_, alpha_,
         options_.max_move};
  seq.dispatch(advect_,
               {e.tile_keys, e.tiles, e.tile_cells, e.fine[0], e.fine[1], e.fine[2], e.fine[3], particles_, features_,
                feature_kinds_, walk_result_, energy_, lost_},
               push, n_)
      .barrier();
  if (measure) seq.dispatch(neighbour_drift_, {particles_, anchors_, drift_bits_}, n_, n_);
  reduce_.record(seq, gpu::ReduceOp::sum, energy_, n_, readback_);
  seq.submit_and_wait();
  IterationStats s;
  s.energy = readback_.read(0);
  s.lost = lost_.read(0);
  if (measure) {
    const uint32_t bits = drift_bits_.read(0);
    float moved;
    std::memcpy(&moved, &bits, sizeof bits);
    if (lists)
      drift_ = moved;
    else
      last_move_ = moved;
  }
  return s;
}

ParticleSystem::PopulationCheck ParticleSystem::check_population(const std::vector<float>& ideals,
                                                                 float delete_factor, float add_factor) {
  gpu::Buffer<float> ideal_buffer(*ctx_, ideals, "feature ideal energies");
  gpu::Buffer<uint32_t> counters(*ctx_, 2 + 2 * ideals.size(), "population counters", gpu::MemoryUse::readback);
  gpu::Sequence seq(*ctx_);
  seq.fill(counters, 0).barrier();
  // The energies at the current positions: over the lists while they hold (no tree work), else by a walk.
  record_energies(seq, lists_hold());
  const struct {
    uint32_t n;
    float delete_factor, add_factor;
  } push{n_, delete_factor, add_factor};
  seq.dispatch(population_flags_, {walk_result_, features_, ideal_buffer, flags_, counters}, push, n_);
  seq.submit_and_wait();
  const std::vector<uint32_t> c = counters.download();
  PopulationCheck r;
  r.delete_candidates = c[0];
  r.add_candidates = c[1];
  for (size_t f = 0; f < ideals.size(); ++f) {
    r.count.push_back(c[3 + 2 * f]);
    r.energy_ratio.push_back(c[3 + 2 * f] ? double(c[2 + 2 * f]) / 64.0 / double(c[3 + 2 * f]) : 0.0);
  }
  return r;
}

uint64_t ParticleSystem::last_node_visits() const {
  if (last_step_listed_) return 0;
  uint64_t total = 0;
  for (uint32_t v : visits_.download()) total += v;
  return total;
}

uint64_t ParticleSystem::last_pair_count() const {
  uint64_t total = 0;
  for (uint32_t c : counts_.download()) total += c & ~octree::TreeWalk::kBudgetExceeded;
  return total;
}

ParticleSystem::RunResult ParticleSystem::run() {
  RunResult r;
  if (n_ == 0) {  // nothing to relax (the stop rule would never see an energy to compare)
    r.converged = true;
    return r;
  }
  double previous = 0;
  for (int it = 0; it < options_.max_iterations; ++it) {
    const IterationStats s = step();
    r.energies.push_back(s.energy);
    r.iterations = it + 1;
    if (it > 0 && s.energy > previous) {
      alpha_ = std::max(alpha_ * 0.5f, options_.alpha / 64.0f);  // the last step overshot: take smaller ones
    } else {
      alpha_ = std::min(alpha_ * 1.1f, options_.alpha);
      if (it > 0 && it + 1 >= options_.min_iterations && previous > 0 && (previous - s.energy) / previous < options_.delta) {
        r.converged = true;
        break;
      }
    }
    previous = s.energy;
  }
  return r;
}

}  // namespace cpmesh::particles
