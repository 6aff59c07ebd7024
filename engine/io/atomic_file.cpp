#include "io/atomic_file.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "io/error.h"

namespace cpmesh::io {

void write_atomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  if (std::error_code ec; fs::is_directory(target, ec)) fail(path, "is a directory, expected a file name to write");
  const fs::path temp = target.string() + ".tmp-" + std::to_string(::getpid());
  try {
    {
      std::ofstream out(temp, std::ios::binary | std::ios::trunc);
      if (!out) fail(path, "cannot create '" + temp.string() + "' (missing directory or no permission)");
      write(out);
      out.flush();
      if (!out) fail(path, "write failed (disk full?)");
    }
    std::error_code ec;
    fs::rename(temp, target, ec);
    if (ec) fail(path, "cannot rename the temporary file into place: " + ec.message());
  } catch (...) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw;
  }
}

}  // namespace cpmesh::io
