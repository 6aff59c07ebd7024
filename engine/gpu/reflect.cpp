#include "gpu/reflect.h"

#include <algorithm>
#include <map>
#include <set>
#include <vector>

#include "gpu/error.h"

namespace cpmesh::gpu {

namespace {

// SPIR-V opcodes and enumerants used below (SPIR-V 1.5 specification, section 3).
enum : uint32_t {
  OpExecutionMode = 16, OpTypeInt = 21, OpTypeFloat = 22, OpTypeVector = 23, OpTypeMatrix = 24, OpTypeImage = 25,
  OpTypeSampledImage = 27, OpTypeArray = 28,
  OpTypeRuntimeArray = 29, OpTypeStruct = 30, OpTypePointer = 32, OpConstant = 43, OpSpecConstant = 50,
  OpVariable = 59, OpDecorate = 71, OpMemberDecorate = 72,
  ExecutionModeLocalSize = 17,
  DecorationSpecId = 1, DecorationArrayStride = 6, DecorationMatrixStride = 7, DecorationBinding = 33,
  DecorationDescriptorSet = 34, DecorationOffset = 35,
  StorageClassUniformConstant = 0, StorageClassUniform = 2, StorageClassPushConstant = 9, StorageClassStorageBuffer = 12,
  DimBuffer = 5,
};

struct Type {
  uint32_t op = 0;
  std::vector<uint32_t> operands;  // words after the result id
};

class Module {
 public:
  explicit Module(const ShaderCode& code) : name_(code.name) {
    if (code.word_count < 5 || code.words[0] != 0x07230203u) fail("not a SPIR-V module");
    for (size_t i = 5; i < code.word_count;) {
      const uint32_t op = code.words[i] & 0xffffu, len = code.words[i] >> 16;
      if (len == 0 || i + len > code.word_count) fail("truncated instruction");
      const uint32_t* w = code.words + i + 1;
      const uint32_t n = len - 1;
      switch (op) {
        case OpExecutionMode:
          if (n >= 5 && w[1] == ExecutionModeLocalSize) std::copy(w + 2, w + 5, layout_.local_size);
          break;
        case OpTypeInt: case OpTypeFloat: case OpTypeVector: case OpTypeMatrix: case OpTypeArray:
        case OpTypeRuntimeArray: case OpTypeStruct: case OpTypePointer: case OpTypeImage: case OpTypeSampledImage:
          types_[w[0]] = Type{op, std::vector<uint32_t>(w + 1, w + n)};
          break;
        case OpConstant:
          if (n >= 3) constants_[w[1]] = w[2];
          break;
        case OpVariable:
          if (n >= 3) variables_.push_back({w[0], w[1], w[2]});
          break;
        case OpDecorate:
          if (n >= 3) decorations_[{w[0], w[1]}] = w[2];
          if (n >= 2 && w[1] == DecorationSpecId) spec_ids_.insert(n >= 3 ? w[2] : 0);
          break;
        case OpMemberDecorate:
          if (n >= 4 && w[2] == DecorationOffset) member_offsets_[{w[0], w[1]}] = w[3];
          break;
        default:
          break;
      }
      i += len;
    }
  }

  ShaderLayout layout() {
    std::set<uint32_t> bindings;
    for (const auto& v : variables_) {
      if (v.storage == StorageClassPushConstant) {
        const Type& ptr = type(v.type_id);
        layout_.push_constant_bytes = size_of(ptr.operands.at(1));
      } else if (v.storage == StorageClassStorageBuffer || v.storage == StorageClassUniform ||
                 v.storage == StorageClassUniformConstant) {
        auto set = decorations_.find({v.id, DecorationDescriptorSet});
        auto binding = decorations_.find({v.id, DecorationBinding});
        if (binding == decorations_.end()) fail("a buffer variable has no binding decoration");
        if (set != decorations_.end() && set->second != 0) fail("descriptor set " + std::to_string(set->second) + " used; only set 0 is supported");
        if (v.storage == StorageClassUniform) fail("uniform buffers are not supported; use std430 storage buffers");
        if (v.storage == StorageClassUniformConstant) {
          // Only a samplerBuffer or usamplerBuffer: OpTypeSampledImage of an OpTypeImage with Dim Buffer, sampled,
          // of 32-bit floats or unsigned integers.
          const Type& pointee = type(type(v.type_id).operands.at(1));
          const Type* image = pointee.op == OpTypeSampledImage ? &type(pointee.operands.at(0)) : nullptr;
          if (!image || image->op != OpTypeImage || image->operands.at(1) != DimBuffer || image->operands.at(5) != 1)
            fail("binding " + std::to_string(binding->second) + ": the only image types supported are samplerBuffer "
                 "and usamplerBuffer");
          const Type& texel = type(image->operands.at(0));
          const bool is_uint = texel.op == OpTypeInt && texel.operands.at(0) == 32 && texel.operands.at(1) == 0;
          if (!is_uint && !(texel.op == OpTypeFloat && texel.operands.at(0) == 32))
            fail("binding " + std::to_string(binding->second) + ": texel buffers hold 32-bit floats or unsigned integers");
          if (binding->second >= 32) fail("a texel buffer at binding 32 or above");
          layout_.texel_buffers |= 1u << binding->second;
          if (is_uint) layout_.uint_texels |= 1u << binding->second;
        }
        if (!bindings.insert(binding->second).second) fail("two variables at binding " + std::to_string(binding->second));
      }
    }
    layout_.bindings = uint32_t(bindings.size());
    if (!bindings.empty() && *bindings.rbegin() != bindings.size() - 1)
      fail("buffer bindings must be 0.." + std::to_string(bindings.size() - 1));
    layout_.spec_constants = uint32_t(spec_ids_.size());
    return layout_;
  }

 private:
  struct Variable {
    uint32_t type_id, id, storage;
  };

  [[noreturn]] void fail(const std::string& what) const {
    throw Error("shader '" + name_ + "': SPIR-V reflection: " + what);
  }
  const Type& type(uint32_t id) const {
    auto it = types_.find(id);
    if (it == types_.end()) fail("unknown type id " + std::to_string(id));
    return it->second;
  }
  uint32_t decoration(uint32_t id, uint32_t what) const {
    auto it = decorations_.find({id, what});
    if (it == decorations_.end()) fail("missing stride decoration on type " + std::to_string(id));
    return it->second;
  }
  uint32_t size_of(uint32_t id) const {
    const Type& t = type(id);
    switch (t.op) {
      case OpTypeInt: case OpTypeFloat: return t.operands.at(0) / 8;
      case OpTypeVector: return size_of(t.operands.at(0)) * t.operands.at(1);
      case OpTypeMatrix: return decoration(id, DecorationMatrixStride) * t.operands.at(1);
      case OpTypeArray: {
        auto len = constants_.find(t.operands.at(1));
        if (len == constants_.end()) fail("array length is not a literal constant");
        return decoration(id, DecorationArrayStride) * len->second;
      }
      case OpTypeStruct: {
        uint32_t size = 0;
        for (uint32_t m = 0; m < t.operands.size(); ++m) {
          auto off = member_offsets_.find({id, m});
          if (off == member_offsets_.end()) fail("struct member without offset");
          size = std::max(size, off->second + size_of(t.operands[m]));
        }
        return size;
      }
      default: fail("unsupported type in a push-constant block");
    }
  }

  std::string name_;
  ShaderLayout layout_;
  std::map<uint32_t, Type> types_;
  std::map<uint32_t, uint32_t> constants_;
  std::vector<Variable> variables_;
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> decorations_;
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> member_offsets_;
  std::set<uint32_t> spec_ids_;
};

}  // namespace

ShaderLayout reflect(const ShaderCode& code) { return Module(code).layout(); }

}  // namespace cpmesh::gpu
