// Closest point lookup by WENO4 interpolation on the closest point embedding (engine/fields/closest_point_embedding.h),
// or, where one of the eight tensor products of one-sided quadratics lies nearer the query, that one (ref/cp_lookup.h:
// the stencil holds two sheets of the feature).
// Reference: ref::cp_lookup (same float32 arithmetic). Include after declaring, in the including shader, as texel
// buffers (lavapipe gathers texels for all lanes; it loads storage buffers lane by lane, see fields/cp_lookup_gpu.h):
//   cp_keys (usamplerBuffer: the tile hash table's keys, two per texel as low, high word), cp_tiles (usamplerBuffer:
//   slot -> tile record, four per texel), cp_cells (usamplerBuffer: 64 per tile record, block or CP_EMPTY, four per
//   texel), cp_fine0..3 (samplerBuffer: the fine points, split in chunks of CP_CHUNK_BLOCKS blocks):
//   fields::GpuEmbedding, fields::EmbeddingTiles
//   and the values CP_DIMS (ivec3), CP_SPACING (vec3), CP_MASK (uint, table size - 1), CP_CHUNK_BLOCKS (uint).
// Specialization constants 0 and 1 (fields::GpuEmbedding::spec_constants): the fine points per voxel and axis, and
// how many fine buffers hold blocks; an embedding in one buffer reads its fine points with no chunk arithmetic.
// Measured on lavapipe (128^3 wedge ball, 13 k particles, advection kernel): 40 ms a dispatch with both as push
// constants, 34 ms as constants. cp_fine_point has one return: an early return for the one-buffer case made the
// kernel slower than before (53 ms; with sub a constant too, 228 ms), as gallivm keeps a return mask live through
// the caller's loops.
// Loops: at most 8 tiles x CP_MAX_PROBES probes (256 iterations per call, far below lavapipe's limit), then the 64
// stencil points.
#ifndef CPMESH_CP_LOOKUP_GLSL
#define CPMESH_CP_LOOKUP_GLSL

layout(constant_id = 0) const int CP_SUB = 2;
layout(constant_id = 1) const uint CP_FINE_CHUNKS = 4;
const uint CP_MAX_PROBES = 32;  // ClosestPointEmbedding::kMaxProbes
const uint CP_EMPTY = 0xffffffffu;
const int CP_TILE_SHIFT = 2;    // EmbeddingTiles::kShift: tiles of 4^3 cells
const float CP_BLEND_MARGIN = 0.005;  // ref::kBlendMargin

uint cp_hash(uvec2 key) {  // fields::embedding_hash
  uint h = key.x ^ (key.y * 0x9e3779b9u);
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}

// Record of (tile, feature) or -1. key = tile << 16 | feature, as two 32-bit words.
int cp_find_tile(uint tile, uint feature) {
  const uvec2 key = uvec2((tile << 16) | feature, tile >> 16);
  uint slot = cp_hash(key) & CP_MASK;
  for (uint probe = 0; probe < CP_MAX_PROBES; ++probe) {
    const uvec4 pair = texelFetch(cp_keys, int(slot >> 1));
    const uvec2 k = (slot & 1u) == 0u ? pair.xy : pair.zw;
    if (k == key) return int(texelFetch(cp_tiles, int(slot >> 2))[slot & 3u]);
    if (k.x == CP_EMPTY && k.y == CP_EMPTY) return -1;
    slot = (slot + 1) & CP_MASK;
  }
  return -1;
}

// The index of the first cell of `tile` on `feature` in cp_cells (its record x 64), or CP_EMPTY where it has none.
uint cp_tile_base(ivec3 tile, ivec3 tile_dims, uint feature) {
  const int record = cp_find_tile(uint((tile.z * tile_dims.y + tile.y) * tile_dims.x + tile.x), feature);
  return record < 0 ? CP_EMPTY : uint(record) << (3 * CP_TILE_SHIFT);
}

float cp_weno4(float f0, float f1, float f2, float f3, float t) {  // ref::weno4
  const float p1 = f1 + 0.5 * (f2 - f0) * t + 0.5 * (f2 - 2.0 * f1 + f0) * t * t;
  const float p2 = f1 + 0.5 * (-f3 + 4.0 * f2 - 3.0 * f1) * t + 0.5 * (f3 - 2.0 * f2 + f1) * t * t;
  const float a = f0 - f1, b = f2 - f1, c = f1 - f2, d = f3 - f2;
  const float is1 = (13.0 * a * a + 26.0 * a * b + 25.0 * b * b) / 12.0;
  const float is2 = (25.0 * c * c + 26.0 * c * d + 13.0 * d * d) / 12.0;
  const float eps = 1e-6;
  const float alpha1 = ((2.0 - t) / 3.0) / ((eps + is1) * (eps + is1));
  const float alpha2 = ((t + 1.0) / 3.0) / ((eps + is2) * (eps + is2));
  return (alpha1 * p1 + alpha2 * p2) / (alpha1 + alpha2);
}

vec4 cp_fine_point(uint block, uint index_in_block) {
  const uint per_block = uint(CP_SUB * CP_SUB * CP_SUB);
  vec4 v;
  if (CP_FINE_CHUNKS == 1u) {
    v = texelFetch(cp_fine0, int(block * per_block + index_in_block));
  } else {
    const uint chunk = block / CP_CHUNK_BLOCKS;
    const int i = int((block - chunk * CP_CHUNK_BLOCKS) * per_block + index_in_block);
    if (chunk == 0) v = texelFetch(cp_fine0, i);
    else if (chunk == 1) v = texelFetch(cp_fine1, i);
    else if (chunk == 2) v = texelFetch(cp_fine2, i);
    else v = texelFetch(cp_fine3, i);
  }
  return v;
}

// ref::weno4_lookup: the sizing (w) is kept within its four samples (see there).
vec4 cp_weno4v(vec4 f0, vec4 f1, vec4 f2, vec4 f3, float t) {
  const float w = clamp(cp_weno4(f0.w, f1.w, f2.w, f3.w, t), min(min(f0.w, f1.w), min(f2.w, f3.w)),
                        max(max(f0.w, f1.w), max(f2.w, f3.w)));
  return vec4(cp_weno4(f0.x, f1.x, f2.x, f3.x, t), cp_weno4(f0.y, f1.y, f2.y, f3.y, t),
              cp_weno4(f0.z, f1.z, f2.z, f3.z, t), w);
}

// ref::quadratic: the quadratics cp_weno4 blends, on samples {-1, 0, 1} (side 0) and {0, 1, 2} (side 1).
vec4 cp_quadratic(vec4 f0, vec4 f1, vec4 f2, vec4 f3, float t, int side) {
  return side == 0 ? f1 + 0.5 * (f2 - f0) * t + 0.5 * (f2 - 2.0 * f1 + f0) * t * t
                   : f1 + 0.5 * (-f3 + 4.0 * f2 - 3.0 * f1) * t + 0.5 * (f3 - 2.0 * f2 + f1) * t * t;
}

void cp_nearer(vec3 c, vec3 query, inout vec3 best, inout float best_d) {
  const float d = length(c - query);
  if (d < best_d) {
    best_d = d;
    best = c;
  }
}

// Closest point (xyz) and sizing (w) for a point in local coordinates on `feature`; valid = false when part of the
// stencil lies outside the feature's band (the point left it), and then the point itself is returned.
// The 4^3 stencil of fine points lies in at most 3^3 cells (sub >= 2; 4^3 for sub = 1), and those in at most 2^3
// tiles: each tile is found once, then each stencil point reads its cell's block from its tile (a texel, gathered for
// all lanes). No arrays indexed by a value known only at run time: lavapipe keeps such an array in memory, lane by
// lane. A table of the cells' blocks filled first cost the advection kernel 6.4-8.4 ms a dispatch against 4.6-6.3
// without (128^3 wedge ball, 13 k particles, one subcell; two subcells 9.3-11.1 against 8.0-9.7); the tiles' eight
// bases as an array rather than the selects below, 5.6-6.5 against 4.0-4.6 (two subcells: 7.9-9.7 against 7.8-8.9).
vec4 cp_lookup(vec3 local_pos, uint feature, out bool valid) {
  valid = false;
  const vec3 u = local_pos / CP_SPACING * float(CP_SUB);
  // Outside the fine grid (NaN included: common.glsl's finite_bits) nothing is found, checked before the conversion
  // to int (ref::cp_lookup).
  if (!finite_bits(u) || any(lessThan(u, vec3(0.0))) || any(greaterThanEqual(u, vec3(CP_DIMS * CP_SUB))))
    return vec4(local_pos, 0.0);
  const vec3 g0 = floor(u);
  const vec3 t = u - g0;
  const ivec3 base = ivec3(g0) - 1;
  if (any(lessThan(base, ivec3(0)))) return vec4(local_pos, 0.0);
  const ivec3 c0 = base / CP_SUB, c1 = (base + 3) / CP_SUB;
  if (any(greaterThanEqual(c1, CP_DIMS))) return vec4(local_pos, 0.0);
  const ivec3 tile_dims = (CP_DIMS + (1 << CP_TILE_SHIFT) - 1) >> CP_TILE_SHIFT;
  const ivec3 t0 = c0 >> CP_TILE_SHIFT, t1 = c1 >> CP_TILE_SHIFT;
  const ivec3 span = t1 - t0;  // 0 or 1 per axis
  const uint b0 = cp_tile_base(t0, tile_dims, feature);
  const uint b1 = span.x > 0 ? cp_tile_base(t0 + ivec3(1, 0, 0), tile_dims, feature) : 0u;
  const uint b2 = span.y > 0 ? cp_tile_base(t0 + ivec3(0, 1, 0), tile_dims, feature) : 0u;
  const uint b3 = span.x > 0 && span.y > 0 ? cp_tile_base(t0 + ivec3(1, 1, 0), tile_dims, feature) : 0u;
  const uint b4 = span.z > 0 ? cp_tile_base(t0 + ivec3(0, 0, 1), tile_dims, feature) : 0u;
  const uint b5 = span.x > 0 && span.z > 0 ? cp_tile_base(t0 + ivec3(1, 0, 1), tile_dims, feature) : 0u;
  const uint b6 = span.y > 0 && span.z > 0 ? cp_tile_base(t0 + ivec3(0, 1, 1), tile_dims, feature) : 0u;
  const uint b7 = all(greaterThan(span, ivec3(0))) ? cp_tile_base(t0 + ivec3(1), tile_dims, feature) : 0u;
  if (b0 == CP_EMPTY || b1 == CP_EMPTY || b2 == CP_EMPTY || b3 == CP_EMPTY || b4 == CP_EMPTY || b5 == CP_EMPTY ||
      b6 == CP_EMPTY || b7 == CP_EMPTY)
    return vec4(local_pos, 0.0);
  bool complete = true;
  // The WENO4 tensor product (w*) and the eight tensor products of one-sided quadratics (q*: a side per axis, x then
  // y then z), as ref::cp_lookup.
  vec4 wy[4], qy00[4], qy01[4], qy10[4], qy11[4];
  for (int z = 0; z < 4; ++z) {
    vec4 wx[4], qx0[4], qx1[4];
    for (int y = 0; y < 4; ++y) {
      vec4 v[4];
      for (int x = 0; x < 4; ++x) {
        const ivec3 f = base + ivec3(x, y, z);
        const ivec3 cell = f / CP_SUB;
        const ivec3 s = f - cell * CP_SUB;
        const ivec3 t = (cell >> CP_TILE_SHIFT) - t0, l = cell & ((1 << CP_TILE_SHIFT) - 1);
        const uint tile_base = t.z == 0 ? (t.y == 0 ? (t.x == 0 ? b0 : b1) : (t.x == 0 ? b2 : b3))
                                        : (t.y == 0 ? (t.x == 0 ? b4 : b5) : (t.x == 0 ? b6 : b7));
        const uint index = tile_base + uint((((l.z << CP_TILE_SHIFT) | l.y) << CP_TILE_SHIFT) | l.x);
        const uint block = texelFetch(cp_cells, int(index >> 2))[index & 3u];
        complete = complete && block != CP_EMPTY;
        v[x] = cp_fine_point(block == CP_EMPTY ? 0u : block, uint((s.z * CP_SUB + s.y) * CP_SUB + s.x));
      }
      wx[y] = cp_weno4v(v[0], v[1], v[2], v[3], t.x);
      qx0[y] = cp_quadratic(v[0], v[1], v[2], v[3], t.x, 0);
      qx1[y] = cp_quadratic(v[0], v[1], v[2], v[3], t.x, 1);
    }
    wy[z] = cp_weno4v(wx[0], wx[1], wx[2], wx[3], t.y);
    qy00[z] = cp_quadratic(qx0[0], qx0[1], qx0[2], qx0[3], t.y, 0);
    qy01[z] = cp_quadratic(qx0[0], qx0[1], qx0[2], qx0[3], t.y, 1);
    qy10[z] = cp_quadratic(qx1[0], qx1[1], qx1[2], qx1[3], t.y, 0);
    qy11[z] = cp_quadratic(qx1[0], qx1[1], qx1[2], qx1[3], t.y, 1);
  }
  if (!complete) return vec4(local_pos, 0.0);
  valid = true;
  const vec4 weno = cp_weno4v(wy[0], wy[1], wy[2], wy[3], t.z);
  vec3 best = weno.xyz;
  float best_d = length(best - local_pos) - CP_BLEND_MARGIN * min(CP_SPACING.x, min(CP_SPACING.y, CP_SPACING.z));
  cp_nearer(cp_quadratic(qy00[0], qy00[1], qy00[2], qy00[3], t.z, 0).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy00[0], qy00[1], qy00[2], qy00[3], t.z, 1).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy01[0], qy01[1], qy01[2], qy01[3], t.z, 0).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy01[0], qy01[1], qy01[2], qy01[3], t.z, 1).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy10[0], qy10[1], qy10[2], qy10[3], t.z, 0).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy10[0], qy10[1], qy10[2], qy10[3], t.z, 1).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy11[0], qy11[1], qy11[2], qy11[3], t.z, 0).xyz, local_pos, best, best_d);
  cp_nearer(cp_quadratic(qy11[0], qy11[1], qy11[2], qy11[3], t.z, 1).xyz, local_pos, best, best_d);
  return vec4(best, weno.w);
}

#endif
