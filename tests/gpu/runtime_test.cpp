// The compute runtime: buffers, kernels (reflection and checks), sequences, profiling, error reporting.
#include <doctest/doctest.h>

#include <fstream>
#include <string>

#include "cpmesh/shaders.h"
#include "gpu/reflect.h"
#include "gpu/sequence.h"
#include "gpu_fixture.h"
#include "primitives/scan.h"
#include "ref/primitives.h"

using namespace cpmesh;
using cpmesh::test::GpuFixture;

TEST_CASE_FIXTURE(GpuFixture, "buffers round-trip data, including empty buffers and partial ranges") {
  const auto data = test::random_u32(10007, 3);
  gpu::Buffer<uint32_t> b(ctx, data, "roundtrip");
  CHECK(b.size() == data.size());
  CHECK(b.bytes() == data.size() * 4);
  CHECK(b.download() == data);
  std::vector<uint32_t> part = {1, 2, 3};
  b.upload(part, 100);
  const auto back = b.download(99, 5);
  CHECK(back == std::vector<uint32_t>{data[99], 1, 2, 3, data[103]});
  CHECK(b.read(101) == 2);

  gpu::Buffer<float> empty(ctx, size_t(0), "empty");
  CHECK(empty.size() == 0);
  CHECK(empty.download().empty());

  gpu::Buffer<double> readback(ctx, 4, "readback", gpu::MemoryUse::readback);
  readback.upload(std::vector<double>{1.5, -2.5, 3.25, 0.0});
  CHECK(readback.download() == std::vector<double>{1.5, -2.5, 3.25, 0.0});
}

TEST_CASE_FIXTURE(GpuFixture, "out-of-range buffer access is an error, not a crash") {
  gpu::Buffer<uint32_t> b(ctx, 10, "small");
  CHECK_THROWS_WITH_AS(b.download(5, 6), doctest::Contains("'small'"), gpu::Error);
  CHECK_THROWS_AS(b.upload(std::vector<uint32_t>(11)), gpu::Error);
}

TEST_CASE_FIXTURE(GpuFixture, "a buffer larger than maxStorageBufferRange gets an error naming both sizes") {
  const uint64_t limit = ctx.info().max_storage_buffer_range;
  const size_t count = size_t(limit / 4 + 1);
  try {
    gpu::Buffer<uint32_t> huge(ctx, count, "huge");
    FAIL("no error for a buffer over the limit");
  } catch (const gpu::Error& e) {
    const std::string msg = e.what();
    CHECK(msg.find("'huge'") != std::string::npos);
    CHECK(msg.find(std::to_string(uint64_t(count) * 4)) != std::string::npos);
    CHECK(msg.find(std::to_string(limit)) != std::string::npos);
    CHECK(msg.find("maxStorageBufferRange") != std::string::npos);
  }
}

TEST_CASE_FIXTURE(GpuFixture, "a texel-only buffer may pass maxStorageBufferRange, but is not bound as a storage buffer") {
  // The closest point embedding's buffers (fields::GpuEmbedding) are read as texels only: their limit is
  // maxTexelBufferElements texels.
  const uint64_t range = ctx.info().max_storage_buffer_range;
  if (ctx.info().max_texel_buffer_elements * 16 <= range) return;  // nothing to test on this device
  const size_t count = size_t(range / 4 + 4);
  gpu::Buffer<uint32_t> wide(ctx, count, "wide", gpu::MemoryUse::texels);
  const std::vector<uint32_t> tail = {1, 2, 3, 4};
  wide.upload(tail, count - 4);
  CHECK(wide.download(count - 4, 4) == tail);
  CHECK_NOTHROW(wide.storage()->texel_view(true));
  gpu::Kernel add(ctx, shaders::scan_add);
  gpu::Buffer<uint32_t> b(ctx, 16, "b");
  gpu::Sequence seq(ctx);
  const struct { uint32_t n; } push{16};
  CHECK_THROWS_WITH_AS(seq.dispatch(add, {wide, b}, push, 16), doctest::Contains("'wide'"), gpu::Error);
  CHECK_THROWS_WITH_AS(gpu::Buffer<uint32_t>(ctx, size_t(ctx.info().max_texel_buffer_elements * 4 + 1), "wider",
                                             gpu::MemoryUse::texels),
                       doctest::Contains("maxTexelBufferElements"), gpu::Error);
}

TEST_CASE_FIXTURE(GpuFixture, "device memory is accounted; released buffers are recycled, then freed oldest first") {
  const uint64_t n = (1u << 20) + 4099;  // a size no other test uses
  const uint64_t before = ctx.memory_stats().current_bytes, allocations = ctx.memory_stats().allocations;
  {
    gpu::Buffer<uint32_t> b(ctx, n, "accounted");
    CHECK(ctx.memory_stats().current_bytes >= before + 4 * n);
    CHECK(ctx.memory_stats().peak_bytes >= before + 4 * n);
    CHECK(ctx.memory_stats().allocations == allocations + 1);
  }
  // Released into the context's pool: still allocated (releasing it may free older pooled buffers beyond the pool's
  // limits, so `before` is no reference any more), and the next buffer of that size takes it.
  const uint64_t held = ctx.memory_stats().current_bytes;
  {
    gpu::Buffer<uint32_t> again(ctx, n, "recycled");
    CHECK(ctx.memory_stats().allocations == allocations + 1);
    CHECK(ctx.memory_stats().current_bytes == held);
    again.upload(std::vector<uint32_t>(n, 7));
    CHECK(again.download(n - 1, 1)[0] == 7);
  }
  // More released buffers than the pool keeps: the oldest, ours among them, are freed.
  {
    std::vector<gpu::Buffer<uint32_t>> many;
    for (size_t i = 0; i < gpu::Context::kPoolEntries + 8; ++i) many.emplace_back(ctx, 7 + i, "many");
  }
  CHECK(ctx.memory_stats().current_bytes < held);
  // Releasing the pool frees what it holds.
  { gpu::Buffer<uint32_t> last(ctx, n, "released"); }
  const uint64_t pooled = ctx.memory_stats().current_bytes;
  ctx.release_pooled();
  CHECK(ctx.memory_stats().current_bytes + 4 * n <= pooled);
}

TEST_CASE("reflection reads bindings, push constants and workgroup size from SPIR-V") {
  const auto scan = gpu::reflect(shaders::scan_blocks);
  CHECK(scan.bindings == 3);
  CHECK(scan.push_constant_bytes == 4);
  CHECK(scan.local_size[0] == 256);
  CHECK(scan.spec_constants == 1);
  const auto scatter = gpu::reflect(shaders::radix_scatter_u64);
  CHECK(scatter.bindings == 5);
  CHECK(scatter.push_constant_bytes == 16);
  const auto reduce = gpu::reflect(shaders::reduce_f32);
  CHECK(reduce.push_constant_bytes == 8);
  CHECK(reduce.bindings == 2);
  CHECK(reduce.texel_buffers == 0);
  const auto lookup = gpu::reflect(shaders::cp_lookup);  // bindings 0-2 usamplerBuffer, 3-6 samplerBuffer
  CHECK(lookup.bindings == 10);
  CHECK(lookup.texel_buffers == 0b1111111u);
  CHECK(lookup.uint_texels == 0b0000111u);

  const uint32_t garbage[6] = {0xdeadbeef, 0, 0, 0, 0, 0};
  CHECK_THROWS_WITH_AS(gpu::reflect(ShaderCode{"garbage", garbage, 6}), doctest::Contains("garbage"), gpu::Error);
  std::vector<uint32_t> truncated(shaders::scan_blocks.words, shaders::scan_blocks.words + 40);
  truncated[39] = 0xffff0000u | 71;  // an instruction claiming 65535 words
  CHECK_THROWS_AS(gpu::reflect(ShaderCode{"truncated", truncated.data(), truncated.size()}), gpu::Error);
}

TEST_CASE_FIXTURE(GpuFixture, "dispatches are checked against the shader's interface") {
  gpu::Kernel add(ctx, shaders::scan_add);
  gpu::Buffer<uint32_t> a(ctx, 16, "a"), b(ctx, 16, "b");
  gpu::Sequence seq(ctx);
  const struct { uint32_t n; } ok{16};
  const struct { uint32_t n, extra; } too_big{16, 0};
  CHECK_THROWS_WITH_AS(seq.dispatch(add, {a}, ok, 16), doctest::Contains("binds 2"), gpu::Error);
  CHECK_THROWS_WITH_AS(seq.dispatch(add, {a, b}, too_big, 16), doctest::Contains("push constants"), gpu::Error);
  CHECK_THROWS_WITH_AS(gpu::Kernel(ctx, shaders::scan_blocks, {1, 2}), doctest::Contains("specialization"), gpu::Error);
  seq.dispatch(add, {a, b}, ok, 16);
  seq.submit_and_wait();
  CHECK_THROWS_WITH_AS(seq.barrier(), doctest::Contains("after it was submitted"), gpu::Error);
}

TEST_CASE_FIXTURE(GpuFixture, "a kernel made again shares its pipeline; other specialization constants get their own") {
  gpu::Kernel a(ctx, shaders::scan_blocks, {0}), b(ctx, shaders::scan_blocks, {0}), flags(ctx, shaders::scan_blocks, {1});
  gpu::Kernel other(ctx, shaders::scan_add);
  CHECK(a.pipeline() == b.pipeline());
  CHECK(a.pipeline() != flags.pipeline());
  CHECK(a.pipeline() != other.pipeline());
  CHECK(flags.name() == "scan_blocks");
  // The shared pipeline computes as the first did: the flag variant counts non-zero values, the other sums them.
  const std::vector<uint32_t> values = {3, 0, 5, 1};
  gpu::Buffer<uint32_t> in(ctx, values, "in"), sums(ctx, 4, "sums"), counted(ctx, 4, "counted");
  gpu::Scan scan(ctx);
  gpu::Sequence seq(ctx);
  scan.record(seq, in, sums, 4);
  scan.record(seq, in, counted, 4, true);
  seq.submit_and_wait();
  CHECK(sums.download() == std::vector<uint32_t>{0, 3, 3, 8});
  CHECK(counted.download() == std::vector<uint32_t>{0, 1, 1, 2});
}

TEST_CASE_FIXTURE(GpuFixture, "a sequence keeps its buffers alive and can be submitted again") {
  gpu::Kernel add(ctx, shaders::scan_add);
  gpu::Buffer<uint32_t> data(ctx, std::vector<uint32_t>(3000, 1), "data");
  gpu::Sequence seq(ctx);
  {
    // Block offsets 0, 10, 20: the offsets buffer goes out of scope on the host before the GPU runs.
    gpu::Buffer<uint32_t> offsets(ctx, std::vector<uint32_t>{0, 10, 20}, "offsets");
    const struct { uint32_t n; } push{3000};
    seq.dispatch(add, {data, offsets}, push, 3 * 256);
  }
  seq.submit_and_wait();
  seq.submit_and_wait();
  const auto out = data.download();
  CHECK(out[0] == 1);
  CHECK(out[1024] == 21);
  CHECK(out[2999] == 41);
}

TEST_CASE("large dispatches are split over y when the group count exceeds the x limit") {
  // A context whose x limit is 3 groups: a 1M-value scan needs 1024 groups per level, so every dispatch is split.
  gpu::Context small(gpu::ContextOptions{"", true, false, 3});
  const uint64_t errors = small.validation_error_count();
  const auto data = test::random_u32((1 << 20) + 77, 5, 100);
  gpu::Buffer<uint32_t> src(small, data, "src"), dst(small, data.size(), "dst"),
      total(small, 1, "total", gpu::MemoryUse::readback);
  gpu::Scan scan(small);
  gpu::Sequence seq(small);
  scan.record(seq, src, dst, uint32_t(data.size()), false, &total);
  seq.submit_and_wait();
  const auto want = ref::exclusive_scan(data);
  CHECK(dst.download() == want);
  CHECK(total.read(0) == want.back() + data.back());
  CHECK(small.validation_error_count() == errors);
}

TEST_CASE("profiling records one timestamp pair per dispatch") {
  gpu::Context profiled(gpu::ContextOptions{"", true, true});
  if (!profiled.info().timestamps) {
    MESSAGE("device has no timestamps; skipped");
    return;
  }
  REQUIRE(profiled.profiling());
  const auto data = test::random_u32(5000, 9);
  gpu::Buffer<uint32_t> src(profiled, data, "src");
  gpu::Scan scan(profiled);
  gpu::Sequence seq(profiled);
  scan.record(seq, src, src, uint32_t(data.size()));  // 5 blocks: scan_blocks twice (two levels), scan_add once
  seq.submit_and_wait();
  const auto& p = profiled.profile();
  REQUIRE(p.count("scan_blocks") == 1);
  CHECK(p.at("scan_blocks").dispatches == 2);
  CHECK(p.at("scan_add").dispatches == 1);
  CHECK(p.at("scan_blocks").total_ms > 0.0);
  CHECK(profiled.validation_error_count() == 0);
}

TEST_CASE("the validation layers are on in the test suites and their errors are caught") {
  gpu::Context checked(gpu::ContextOptions{"", true, false});
  const bool installed = std::ifstream("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json").good();
  if (!installed) {
    MESSAGE("vulkan-validationlayers is not installed; validation is off");
    return;
  }
  REQUIRE(checked.validation_enabled());
  CHECK(checked.validation_error_count() == 0);
  // A deliberate API misuse: a descriptor pool with maxSets = 0 (VUID-VkDescriptorPoolCreateInfo-maxSets-00301).
  const vk::DescriptorPoolSize size(vk::DescriptorType::eStorageBuffer, 1);
  vk::raii::DescriptorPool pool(checked.device(), vk::DescriptorPoolCreateInfo({}, 0, size));
  CHECK(checked.validation_error_count() >= 1);
  CHECK(checked.validation_errors().front().find("maxSets") != std::string::npos);
}

TEST_CASE("the staging path (device memory that is not mapped) uploads, downloads and computes correctly") {
  gpu::Context staged(gpu::ContextOptions{"", true, false, 0, true});
  REQUIRE_FALSE(staged.unified_memory());
  const auto data = test::random_u32(70001, 21, 1000);
  gpu::Buffer<uint32_t> src(staged, data, "staged src"), dst(staged, data.size(), "staged dst");
  CHECK(src.download() == data);
  std::vector<uint32_t> part = {7, 8, 9};
  src.upload(part, 500);
  CHECK(src.download(499, 5) == std::vector<uint32_t>{data[499], 7, 8, 9, data[503]});
  src.upload(data);
  gpu::Scan scan(staged);
  gpu::Sequence seq(staged);
  scan.record(seq, src, dst, uint32_t(data.size()));
  seq.submit_and_wait();
  CHECK(dst.download() == ref::exclusive_scan(data));
  CHECK(staged.validation_error_count() == 0);
}
