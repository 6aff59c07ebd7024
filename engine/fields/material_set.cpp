#include "fields/material_set.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cpmesh::fields {

MaterialSet::MaterialSet(std::span<const uint16_t> members) {
  if (members.empty() || members.size() > size_t(kSlots))
    throw std::invalid_argument("a material set holds 1 to 4 materials, got " + std::to_string(members.size()));
  bits_ = 0;
  for (int s = 0; s < kSlots; ++s) {
    const uint16_t m = members[std::min(size_t(s), members.size() - 1)];
    if (m == kNone) throw std::invalid_argument("a material set's material index must be below 65535");
    bits_ |= uint64_t(m) << (16 * s);
  }
}

MaterialSet MaterialSet::common(MaterialSet other) const {
  int first = -1;
  for (int s = 0; s < kSlots && first < 0; ++s)
    if (other.has(slot(s))) first = s;
  if (first < 0) return {};
  uint64_t bits = 0;
  for (int s = 0; s < kSlots; ++s) bits |= uint64_t(other.has(slot(s)) ? slot(s) : slot(first)) << (16 * s);
  return from_packed(bits);
}

std::vector<uint16_t> MaterialSet::members() const {
  std::vector<uint16_t> out;
  for (int s = 0; s < kSlots; ++s)
    if (slot(s) != kNone) out.push_back(slot(s));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool needs_exact_sets(std::span<const MaterialSet> sets) {
  for (const MaterialSet& s : sets)
    for (int k = 0; k < MaterialSet::kSlots; ++k)
      if (s.slot(k) != MaterialSet::kNone && s.slot(k) >= 64) return true;
  return false;
}

std::vector<uint16_t> union_of(std::span<const MaterialSet> sets, std::initializer_list<uint16_t> more) {
  std::vector<uint16_t> out(more);
  for (const MaterialSet& s : sets)
    for (int k = 0; k < MaterialSet::kSlots; ++k)
      if (s.slot(k) != MaterialSet::kNone) out.push_back(s.slot(k));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

MaterialList::MaterialList(std::vector<uint16_t> members) : members_(std::move(members)) {
  std::sort(members_.begin(), members_.end());
  members_.erase(std::unique(members_.begin(), members_.end()), members_.end());
}

std::vector<uint16_t> union_of(std::span<const MaterialList> lists, std::initializer_list<uint16_t> more) {
  std::vector<uint16_t> out(more);
  for (const MaterialList& l : lists) out.insert(out.end(), l.members().begin(), l.members().end());
  return MaterialList(std::move(out)).members();
}

}  // namespace cpmesh::fields
