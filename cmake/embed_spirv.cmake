# cmake -DSPV=in.spv -DOUT=out.cpp -DSYMBOL=name -P embed_spirv.cmake
# Turns a SPIR-V binary into a C++ source defining cpmesh::shaders::<SYMBOL> (little-endian words).
file(READ ${SPV} hex HEX)
string(LENGTH "${hex}" n)
math(EXPR rem "${n} % 8")
if(NOT rem EQUAL 0 OR n EQUAL 0)
  message(FATAL_ERROR "${SPV}: ${n} hex digits is not a whole number of 32-bit SPIR-V words")
endif()
string(REGEX REPLACE "([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])" "0x\\4\\3\\2\\1u," words "${hex}")
string(REGEX REPLACE "(0x[0-9a-f]+u,0x[0-9a-f]+u,0x[0-9a-f]+u,0x[0-9a-f]+u,0x[0-9a-f]+u,0x[0-9a-f]+u,0x[0-9a-f]+u,0x[0-9a-f]+u,)" "\\1\n" words "${words}")
math(EXPR count "${n} / 8")
file(WRITE ${OUT}.tmp
"// Generated from ${SPV} by cmake/embed_spirv.cmake. Do not edit.
#include <cstdint>
#include \"gpu/shader_code.h\"
namespace cpmesh::shaders {
namespace {
const uint32_t words[${count}] = {
${words}
};
}  // namespace
extern const ShaderCode ${SYMBOL};
const ShaderCode ${SYMBOL}{\"${SYMBOL}\", words, ${count}};
}  // namespace cpmesh::shaders
")
file(RENAME ${OUT}.tmp ${OUT})
