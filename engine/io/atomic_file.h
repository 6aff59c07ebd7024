#pragma once
// Every writer goes through here: the content goes to "<name>.tmp-<pid>" in the same directory (same file system, so
// the rename is atomic) and is renamed over the final name only when complete. A failure, an exception from `write`
// included, removes the temporary, so a half-written file never appears under the final name.
#include <functional>
#include <ostream>
#include <string>

namespace cpmesh::io {

void write_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace cpmesh::io
