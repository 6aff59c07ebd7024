#include "io/scalar_type.h"

#include <bit>
#include <cstring>

namespace cpmesh::io {

size_t scalar_size(ScalarType t) {
  switch (t) {
    case ScalarType::u8:
    case ScalarType::i8: return 1;
    case ScalarType::u16:
    case ScalarType::i16: return 2;
    case ScalarType::u32:
    case ScalarType::i32:
    case ScalarType::f32: return 4;
    case ScalarType::f64: return 8;
  }
  return 1;
}

bool is_integer(ScalarType t) { return t != ScalarType::f32 && t != ScalarType::f64; }

std::string scalar_name(ScalarType t) {
  switch (t) {
    case ScalarType::u8: return "uint8";
    case ScalarType::i8: return "int8";
    case ScalarType::u16: return "uint16";
    case ScalarType::i16: return "int16";
    case ScalarType::u32: return "uint32";
    case ScalarType::i32: return "int32";
    case ScalarType::f32: return "float32";
    case ScalarType::f64: return "float64";
  }
  return "?";
}

bool host_is_big_endian() { return std::endian::native == std::endian::big; }

namespace {

template <typename T>
T load_as(const unsigned char* p, bool swap) {
  unsigned char b[sizeof(T)];
  for (size_t i = 0; i < sizeof(T); ++i) b[i] = swap ? p[sizeof(T) - 1 - i] : p[i];
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

template <typename T>
void store_as(std::string& out, T v, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  for (size_t i = 0; i < sizeof(T); ++i) out.push_back(char(swap ? b[sizeof(T) - 1 - i] : b[i]));
}

}  // namespace

double load_sample(const unsigned char* data, size_t index, ScalarType t, bool big_endian) {
  const bool swap = big_endian != host_is_big_endian();
  const unsigned char* p = data + index * scalar_size(t);
  switch (t) {
    case ScalarType::u8: return p[0];
    case ScalarType::i8: return int8_t(p[0]);
    case ScalarType::u16: return load_as<uint16_t>(p, swap);
    case ScalarType::i16: return load_as<int16_t>(p, swap);
    case ScalarType::u32: return load_as<uint32_t>(p, swap);
    case ScalarType::i32: return load_as<int32_t>(p, swap);
    case ScalarType::f32: return load_as<float>(p, swap);
    case ScalarType::f64: return load_as<double>(p, swap);
  }
  return 0;
}

void store_sample(std::string& out, double value, ScalarType t, bool big_endian) {
  const bool swap = big_endian != host_is_big_endian();
  switch (t) {
    case ScalarType::u8: out.push_back(char(uint8_t(value))); break;
    case ScalarType::i8: out.push_back(char(int8_t(value))); break;
    case ScalarType::u16: store_as(out, uint16_t(value), swap); break;
    case ScalarType::i16: store_as(out, int16_t(value), swap); break;
    case ScalarType::u32: store_as(out, uint32_t(value), swap); break;
    case ScalarType::i32: store_as(out, int32_t(value), swap); break;
    case ScalarType::f32: store_as(out, float(value), swap); break;
    case ScalarType::f64: store_as(out, value, swap); break;
  }
}

}  // namespace cpmesh::io
