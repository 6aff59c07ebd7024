// shaders/cp_lookup.comp against ref::cp_lookup on the sphere and the wedge ball embeddings.
#include <doctest/doctest.h>

#include <limits>
#include <random>

#include "fields/cp_lookup_gpu.h"
#include "fields/device_fields.h"
#include "gpu_fixture.h"
#include "ref/cp_lookup.h"
#include "fields_volumes.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

namespace {

void compare(gpu::Context& ctx, const fields::ClosestPointEmbedding& E, const std::vector<glm::vec4>& queries,
             uint64_t max_chunk_bytes = 0) {
  fields::GpuEmbedding ge(ctx, E, max_chunk_bytes);
  fields::CpLookup lookup(ctx);
  const uint32_t n = uint32_t(queries.size());
  gpu::Buffer<glm::vec4> q(ctx, queries, "queries"), results(ctx, n, "results");
  gpu::Buffer<uint32_t> valid(ctx, n, "valid");
  gpu::Sequence seq(ctx);
  lookup.record(seq, ge, q, results, valid, n);
  seq.submit_and_wait();
  const auto got = results.download();
  const auto got_valid = valid.download();
  size_t n_valid = 0;
  float worst = 0, worst_w = 0, lowest_w = 1e30f;
  for (uint32_t i = 0; i < n; ++i) {
    const auto want = ref::cp_lookup(E, glm::vec3(queries[i]), glm::floatBitsToUint(queries[i].w));
    REQUIRE(bool(got_valid[i]) == want.valid);
    if (!want.valid) continue;
    ++n_valid;
    worst = std::max(worst, glm::length(glm::vec3(got[i]) - glm::vec3(want.value)));
    worst_w = std::max(worst_w, std::fabs(got[i].w - want.value.w));
    lowest_w = std::min(lowest_w, got[i].w);
  }
  MESSAGE(n_valid << " of " << n << " lookups valid; max GPU - reference difference " << worst << " voxel, sizing "
                  << worst_w << ", lowest sizing " << lowest_w);
  CHECK(n_valid > n / 2);
  CHECK(worst < 1e-5f);
  CHECK(worst_w < 1e-5f);
  float lowest_stored = 1e30f;
  for (const auto& f : E.fine) lowest_stored = std::min(lowest_stored, f.w);
  CHECK(lowest_w >= lowest_stored);  // the lookup step clamps the sizing to its samples (ref::weno4_lookup)
}

// Queries around a sphere of radius 16: mostly near the surface, some far from it (invalid), one outside the grid.
std::vector<glm::vec4> sphere_queries(const test::FieldsVolume& vol) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> off(-3.0, 3.0);
  std::vector<glm::vec4> queries;
  for (int i = 0; i < 4000; ++i) {
    const glm::dvec3 dir = glm::normalize(glm::dvec3(n01(rng), n01(rng), n01(rng)));
    queries.emplace_back(glm::vec3(vol.centre + dir * (16.0 + off(rng))), glm::uintBitsToFloat(0u));
  }
  queries.emplace_back(-5.0f, 3.0f, 3.0f, glm::uintBitsToFloat(0u));
  // A NaN and far-off queries find nothing (an int conversion of them is undefined on the device too).
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const glm::vec3 p : {glm::vec3(nan), glm::vec3(3e9f), glm::vec3(-3e9f), glm::vec3(vol.centre) + glm::vec3(nan, 0, 0)})
    queries.emplace_back(p, glm::uintBitsToFloat(0u));
  return queries;
}

}  // namespace

TEST_CASE_FIXTURE(GpuFixture, "GPU closest point lookup matches the reference: sphere, two subcells and one") {
  const auto vol = test::make_volume(io::SynthShape::sphere, 48, 16.0);
  for (const int sub : {2, 1}) {
    CAPTURE(sub);
    fields::EmbeddingOptions o;
    o.sub = sub;
    fields::IndicatorOptions io;
    io.band = fields::embedding_indicator_band(o, sub);
    const auto F = fields::build_indicator_fields(vol.grid, vol.labels.data(), io);
    const auto E = fields::build_closest_point_embedding(F, o);
    REQUIRE(E.sub == sub);
    compare(ctx, E, sphere_queries(vol));
    // A sizing with valleys one sample wide, where WENO4 alone undershoots (to below zero): the clamp on both sides.
    auto valleys = E;
    for (size_t i = 0; i < valleys.fine.size(); ++i) valleys.fine[i].w = i % 3 == 0 ? 4.0f : 0.25f;
    compare(ctx, valleys, sphere_queries(vol));
  }
}

TEST_CASE_FIXTURE(GpuFixture, "GPU closest point lookup matches the reference: wedge ball, every feature") {
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 40);
  const auto F = fields::build_indicator_fields(wb.grid, wb.labels.data());
  const auto E = fields::build_closest_point_embedding(F);
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> jitter(-0.7f, 0.7f);
  std::vector<glm::vec4> queries;
  // Points near stored closest points of every block, tagged with that block's feature.
  for (size_t slot = 0; slot < E.keys.size(); ++slot) {
    if (E.keys[slot] == fields::ClosestPointEmbedding::kEmpty || rng() % 6) continue;
    const uint32_t feature = uint32_t(E.keys[slot] & 0xffff);
    const glm::vec3 cp(E.fine[size_t(E.blocks[slot]) * 8]);
    queries.emplace_back(cp + glm::vec3(jitter(rng), jitter(rng), jitter(rng)), glm::uintBitsToFloat(feature));
  }
  REQUIRE(queries.size() > 1000);
  compare(ctx, E, queries);
  // The fine points split over all four chunk buffers give the same answers.
  const uint64_t chunk = uint64_t((E.block_count() + 3) / 4) * 8 * sizeof(glm::vec4);
  compare(ctx, E, queries, chunk);
  CHECK_THROWS_WITH_AS(fields::GpuEmbedding(ctx, E, chunk / 4), doctest::Contains("blocks"), gpu::Error);
  // The same test, as the fields stage runs it before the embedding's fine points (EmbeddingOptions::check_blocks).
  CHECK_NOTHROW(fields::GpuEmbedding::check_fits(ctx, E.block_count(), E.sub, chunk));
  CHECK_THROWS_WITH_AS(fields::GpuEmbedding::check_fits(ctx, E.block_count(), E.sub, chunk / 4),
                       doctest::Contains((std::to_string(E.block_count()) + " blocks").c_str()), gpu::Error);
}

TEST_CASE_FIXTURE(GpuFixture, "device fields: one subcell where two would not fit the bindings, an error where one does not") {
  const auto wb = test::make_volume(io::SynthShape::wedge_ball, 32);
  io::LabelVolume volume;
  volume.dims = {32, 32, 32};
  volume.spacing = {1, 1, 1};
  volume.labels = wb.labels;
  volume.source = "wb32.nrrd";
  const auto two = fields::build_device_fields(ctx, volume, {});
  REQUIRE(two.fields.embedding.sub == 2);
  CHECK(two.one_subcell_because.empty());
  const size_t blocks = two.fields.embedding.block_count();
  // Chunks of 8 x blocks bytes: 4 of them hold blocks / 4 blocks of two subcells, 2 x blocks of one.
  const auto one = fields::build_device_fields(ctx, volume, {}, 8 * blocks);
  CHECK(one.fields.embedding.sub == 1);
  CHECK(one.fields.fields.band > two.fields.fields.band);  // one subcell needs a deeper band (embedding_indicator_band)
  // The refusal of two, from the curve pass's count (within 2% of the final one).
  CHECK(doctest::String(one.one_subcell_because.c_str()) == doctest::Contains("binds at most 4 x"));
  // Where the subcells are fixed, or one does not fit either: an error naming the volume, before the fine points.
  fields::FieldsOptions fixed;
  fixed.embedding.sub = 2;
  CHECK_THROWS_WITH_AS(fields::build_device_fields(ctx, volume, fixed, 8 * blocks), doctest::Contains("wb32.nrrd: "),
                       fields::EmbeddingTooLarge);
  CHECK_THROWS_WITH_AS(fields::build_device_fields(ctx, volume, {}, 64), doctest::Contains("wb32.nrrd: "),
                       fields::EmbeddingTooLarge);
}
