#pragma once
// The one exception type of the I/O layer. Messages name the file, the field and what was expected, so a user can fix
// the input without reading our code: "scan.nrrd: field 'sizes': expected 3 positive integers, got '64 0 64'".
#include <stdexcept>
#include <string>

namespace cpmesh::io {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// "<file>: field '<field>': expected <expected>, got '<got>'".
[[noreturn]] void fail_field(const std::string& file, const std::string& field, const std::string& expected,
                             const std::string& got);
// "<file>: <what>" for errors that are not about one header field (missing file, corrupt stream).
[[noreturn]] void fail(const std::string& file, const std::string& what);

}  // namespace cpmesh::io
