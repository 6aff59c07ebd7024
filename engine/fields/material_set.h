#pragma once
// The materials of a feature (docs/design.md, "Materials"): up to four material indices in the four 16-bit slots of
// one 64-bit word, so a material index may be anything below kNone and the number of materials is not bounded by a
// bit mask. Every slot holds a member and every member has a slot, in any order and repeated as needed; all slots
// kNone is the empty set. The particle system's interaction rule asks whether one set includes another, the tree
// walk's lumping the intersection of a node's sets; both work slot by slot, which the shaders do the same way on two
// 32-bit words (shaders/shared/material_set.glsl: slots 0 and 1 in x, low half first, 2 and 3 in y). With fewer than
// 64 materials one AND of bit masks (mask64) answers both, and the shaders compare only those.
#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <utility>
#include <vector>

namespace cpmesh::fields {

class MaterialSet {
 public:
  static constexpr uint16_t kNone = 0xffff;
  static constexpr int kSlots = 4;

  MaterialSet() = default;  // empty
  // 1 to 4 distinct or repeated material indices below kNone, in any order; throws std::invalid_argument otherwise.
  explicit MaterialSet(std::span<const uint16_t> members);
  MaterialSet(std::initializer_list<uint16_t> members) : MaterialSet(std::span(members.begin(), members.size())) {}
  static MaterialSet from_packed(uint64_t packed) {
    MaterialSet s;
    s.bits_ = packed;
    return s;
  }

  uint64_t packed() const { return bits_; }  // the four slots, slot 0 in the low 16 bits
  // Bit m % 64 for each member m: for sets of materials below 64 the set itself, as a bit mask (one AND tests
  // inclusion); for larger indices a filter that every including set passes and most others fail.
  uint64_t mask64() const {
    uint64_t m = 0;
    for (int s = 0; s < kSlots; ++s)
      if (slot(s) != kNone) m |= uint64_t(1) << (slot(s) & 63);
    return m;
  }
  uint16_t slot(int s) const { return uint16_t(bits_ >> (16 * s)); }
  bool empty() const { return slot(0) == kNone; }
  bool has(uint16_t m) const { return m != kNone && in_slots(m); }
  // Every slot of `other` is a slot of this set: every member of `other` is one of this set's (slot by slot, as the
  // shaders test it, so the empty set includes only itself).
  bool includes(MaterialSet other) const {
    for (int s = 0; s < kSlots; ++s)
      if (!in_slots(other.slot(s))) return false;
    return true;
  }
  // The members of this set that `other` has: slot s keeps this set's slot s where `other` has it, else takes the
  // first slot that `other` has; empty when there is none. The shader computes the same bits.
  MaterialSet common(MaterialSet other) const;
  std::vector<uint16_t> members() const;  // ascending, distinct

 private:
  bool in_slots(uint16_t v) const { return slot(0) == v || slot(1) == v || slot(2) == v || slot(3) == v; }
  uint64_t bits_ = ~uint64_t(0);
};

// Whether mask64 is exact for these sets (every member below 64); where it is not, the shaders also compare the
// slots (their EXACT_SETS specialization).
bool needs_exact_sets(std::span<const MaterialSet> sets);

// The union of the members of some sets and some more materials, ascending and distinct.
std::vector<uint16_t> union_of(std::span<const MaterialSet> sets, std::initializer_list<uint16_t> more = {});

// Any number of materials, ascending and distinct: the host's per-vertex sets in the restricted Delaunay, where a
// vertex may stand for junctions closer together than the refinement separates (mesh/refine.h,
// widen_to_near_junctions): around a voxel corner up to eight labels meet, more than four slots hold.
class MaterialList {
 public:
  MaterialList() = default;
  MaterialList(MaterialSet set) : members_(set.members()) {}  // NOLINT: every set is a list
  explicit MaterialList(std::vector<uint16_t> members);
  bool has(uint16_t m) const { return std::binary_search(members_.begin(), members_.end(), m); }
  const std::vector<uint16_t>& members() const { return members_; }
  size_t size() const { return members_.size(); }

 private:
  std::vector<uint16_t> members_;
};

// The union of the members of some lists and some more materials, ascending and distinct.
std::vector<uint16_t> union_of(std::span<const MaterialList> lists, std::initializer_list<uint16_t> more = {});

}  // namespace cpmesh::fields
