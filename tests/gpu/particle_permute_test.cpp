// shaders/particle_permute.comp against ref::particle_permute, and the particle system's slots in Morton order
// behind an API that keeps the caller's order.
#include <doctest/doctest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "gpu_fixture.h"
#include "particles/particle_permute.h"
#include "ref/particle_permute.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

TEST_CASE_FIXTURE(GpuFixture, "GPU particle permute matches the reference exactly and leaves the identity order") {
  particles::ParticlePermute permute(ctx);
  for (uint32_t n : {1u, 255u, 256u, 257u, 5000u}) {
    CAPTURE(n);
    std::mt19937 rng(n);
    std::uniform_real_distribution<float> u(-10.0f, 10.0f);
    std::vector<glm::vec4> particles(n);
    for (auto& p : particles) p = glm::vec4(u(rng), u(rng), u(rng), u(rng));
    std::vector<uint32_t> features(n), ids(n), order(n);
    for (auto& f : features) f = uint32_t(rng() % 7);
    for (auto& i : ids) i = uint32_t(rng());
    std::vector<glm::uvec4> masks(n);
    for (auto& m : masks) m = glm::uvec4(rng(), rng(), rng(), rng());
    std::iota(order.begin(), order.end(), 0u);
    std::shuffle(order.begin(), order.end(), rng);
    gpu::Buffer<uint32_t> order_b(ctx, order, "order"), features_b(ctx, features, "features"), ids_b(ctx, ids, "ids"),
        features_out(ctx, n, "features out"), ids_out(ctx, n, "ids out");
    gpu::Buffer<glm::vec4> particles_b(ctx, particles, "particles"), particles_out(ctx, n, "particles out");
    gpu::Buffer<glm::uvec4> masks_b(ctx, masks, "masks"), masks_out(ctx, n, "masks out");
    gpu::Sequence seq(ctx);
    permute.record(seq, order_b, particles_b, features_b, ids_b, masks_b, particles_out, features_out, ids_out,
                   masks_out, n);
    seq.submit_and_wait();
    const auto want = ref::particle_permute(order, particles, features, ids, masks);
    CHECK(particles_out.download() == want.particles);
    CHECK(features_out.download() == want.features);
    CHECK(ids_out.download() == want.ids);
    CHECK(masks_out.download() == want.masks);
    CHECK(order_b.download() == want.order);
    CHECK(want.particles[n / 2] == particles[order[n / 2]]);  // the reference itself: slot q holds order[q]
  }
  gpu::Buffer<uint32_t> one(ctx, 1, "one");
  gpu::Buffer<glm::vec4> p(ctx, 1, "p");
  gpu::Buffer<glm::uvec4> m(ctx, 1, "m");
  gpu::Sequence seq(ctx);
  CHECK_THROWS_AS(permute.record(seq, one, p, one, one, m, p, one, one, m, 2), gpu::Error);
}
