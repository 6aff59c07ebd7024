// fields::MaterialSet as uvec2 (engine/fields/material_set.h): four 16-bit material slots, 0 and 1 in x (low half
// first), 2 and 3 in y; each slot a member, all 0xffff the empty set. The tests work on both halves of a word at once.
// A particle's texel holds its set's mask64 (bit m % 64 per member) in xy and its slots in zw; with EXACT_SETS 0 (every
// material below 64) the masks alone decide, and the slots are never compared.
layout(constant_id = 0) const uint EXACT_SETS = 0;

// Non-zero halves where a half of x is zero (exact as an any-test: a borrow only reaches a half above a zero one).
uvec2 ms_zero_halves(uvec2 x) { return (x - 0x00010001u) & ~x & 0x80008000u; }

// 1 when the material in both halves of m2 (m * 0x10001) is a member of s, else 0.
uint ms_has2(uvec2 s, uint m2) {
  const uvec2 z = ms_zero_halves(s ^ uvec2(m2));
  return uint((z.x | z.y) != 0u);
}

// The slots of a, each in both halves of a word: what ms_includes compares, computed once per walker.
uvec4 ms_slots2(uvec2 a) {
  return uvec4(a.x & 0xffffu, a.x >> 16, a.y & 0xffffu, a.y >> 16) * 0x10001u;
}

// Every member of the set whose slots are a2 (ms_slots2) is a member of s.
bool ms_includes(uvec2 s, uvec4 a2) {
  return (ms_has2(s, a2.x) & ms_has2(s, a2.y) & ms_has2(s, a2.z) & ms_has2(s, a2.w)) != 0u;
}

// The particle system's rule: the set of texel s includes the walker's (mask64 `bits`, slots2 `slots`).
bool ms_texel_includes(uvec4 s, uvec2 bits, uvec4 slots) {
  return (s.xy & bits) == bits && (EXACT_SETS == 0u || ms_includes(s.zw, slots));
}

// MaterialSet::common: slot k keeps a's slot k where b has it, else takes a's first slot that b has; empty if none.
uvec2 ms_common(uvec2 a, uvec2 b) {
  const uvec4 a2 = ms_slots2(a);
  const uvec4 keep = uvec4(ms_has2(b, a2.x), ms_has2(b, a2.y), ms_has2(b, a2.z), ms_has2(b, a2.w));
  const uvec4 slots = a2 & 0xffffu;
  const uint first = keep.x != 0u ? slots.x
                   : keep.y != 0u ? slots.y
                   : keep.z != 0u ? slots.z
                   : keep.w != 0u ? slots.w
                                  : 0xffffu;
  const uvec4 kept = mix(uvec4(first), slots, bvec4(keep));
  return uvec2(kept.x | (kept.y << 16), kept.z | (kept.w << 16));
}
