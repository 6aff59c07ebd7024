#include "io/error.h"

namespace cpmesh::io {

void fail_field(const std::string& file, const std::string& field, const std::string& expected,
                const std::string& got) {
  // Header values can be binary garbage: keep the message printable and short.
  std::string shown;
  for (char c : got.substr(0, 80)) shown += (c >= 32 && c < 127) ? c : '?';
  if (got.size() > 80) shown += "...";
  throw Error(file + ": field '" + field + "': expected " + expected + ", got '" + shown + "'");
}

void fail(const std::string& file, const std::string& what) { throw Error(file + ": " + what); }

}  // namespace cpmesh::io
