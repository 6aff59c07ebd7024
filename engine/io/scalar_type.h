#pragma once
// Sample types of volume files and their conversion to and from bytes in either byte order.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cpmesh::io {

enum class ScalarType { u8, i8, u16, i16, u32, i32, f32, f64 };

size_t scalar_size(ScalarType t);
bool is_integer(ScalarType t);
std::string scalar_name(ScalarType t);  // "uint8", "int16", "float32", ...

// True on big-endian hosts; files say their own byte order and samples are swapped when it differs.
bool host_is_big_endian();

// Sample `index` of a packed array of `t` in the given byte order, widened to double (exact for all types here).
double load_sample(const unsigned char* data, size_t index, ScalarType t, bool big_endian);
// Appends `value` (already range-checked by the caller) as one sample of `t`.
void store_sample(std::string& out, double value, ScalarType t, bool big_endian);

}  // namespace cpmesh::io
