#pragma once
// Work that can kill its process, run in a forked child. TetGen 1.5 as Debian builds it frees its mesh when it gives
// up (terminatetetgen) and again while tetrahedralize unwinds, so a failure in boundary recovery (facets that
// intersect, say) is a double free that kills the process instead of an error it could report. The child sends its
// result (or the message of the exception it threw) back through a pipe; a child that dies becomes an exception that
// names the signal. Several children may run at once, one per calling thread: each call has its own pipe, and a child
// closes every other descriptor it inherited (so a sibling's death is seen when it happens, not when this child ends).
//
// The child is a copy of the caller with only the calling thread, so a job must not use the thread pool (TBB) or
// anything another thread may hold locked; plain computation and malloc are safe.
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

namespace cpmesh::mesh {

// Runs job() in a forked child and returns the bytes it returned. `what` names the work in error messages.
// Throws std::runtime_error with the job's own message when it threw, or with the signal when the child died.
std::string run_in_child(const std::string& what, const std::function<std::string()>& job);

// The child's result as bytes: vectors of trivially copyable values, each with its length, read back in order.
class ByteWriter {
 public:
  template <class T>
  void put(const std::vector<T>& v) {
    const uint64_t n = v.size();
    buf_.append(reinterpret_cast<const char*>(&n), sizeof n);
    buf_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  template <class T>
  void put_value(const T& x) { put(std::vector<T>{x}); }
  std::string take() { return std::move(buf_); }

 private:
  std::string buf_;
};

class ByteReader {
 public:
  explicit ByteReader(const std::string& buf) : buf_(buf) {}
  // False when the bytes end early (then v is unspecified).
  template <class T>
  bool get(std::vector<T>& v) {
    uint64_t n = 0;
    if (buf_.size() - at_ < sizeof n) return false;
    std::memcpy(&n, buf_.data() + at_, sizeof n);
    at_ += sizeof n;
    if ((buf_.size() - at_) / sizeof(T) < n) return false;
    v.resize(size_t(n));
    std::memcpy(static_cast<void*>(v.data()), buf_.data() + at_, size_t(n) * sizeof(T));
    at_ += size_t(n) * sizeof(T);
    return true;
  }
  template <class T>
  bool get_value(T& x) {
    std::vector<T> v;
    if (!get(v) || v.size() != 1) return false;
    x = v[0];
    return true;
  }
  bool done() const { return at_ == buf_.size(); }

 private:
  const std::string& buf_;
  size_t at_ = 0;
};

}  // namespace cpmesh::mesh
