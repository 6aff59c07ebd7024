#include "io/header_text.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "io/error.h"

namespace cpmesh::io {

std::string trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<std::string> split_words(std::string_view s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

std::string to_lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

int64_t parse_int(const std::string& file, const std::string& field, const std::string& text) {
  const std::string t = trim(text);
  int64_t v = 0;
  const char* b = t.data() + (t.size() > 0 && t[0] == '+' ? 1 : 0);
  const auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || p != t.data() + t.size()) fail_field(file, field, "an integer", text);
  return v;
}

double parse_double(const std::string& file, const std::string& field, const std::string& text) {
  const std::string t = trim(text);
  double v = 0;
  const char* b = t.data() + (t.size() > 0 && t[0] == '+' ? 1 : 0);
  const auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || p != t.data() + t.size() || !std::isfinite(v))
    fail_field(file, field, "a finite number", text);
  return v;
}

std::vector<int64_t> parse_ints(const std::string& file, const std::string& field, const std::string& text, size_t n,
                                const std::string& expected) {
  const auto words = split_words(text);
  if (words.size() != n) fail_field(file, field, expected, text);
  std::vector<int64_t> out;
  for (const auto& w : words) {
    try {
      out.push_back(parse_int(file, field, w));
    } catch (const Error&) {
      fail_field(file, field, expected, text);
    }
  }
  return out;
}

std::vector<double> parse_doubles(const std::string& file, const std::string& field, const std::string& text, size_t n,
                                  const std::string& expected) {
  const auto words = split_words(text);
  if (words.size() != n) fail_field(file, field, expected, text);
  std::vector<double> out;
  for (const auto& w : words) {
    try {
      out.push_back(parse_double(file, field, w));
    } catch (const Error&) {
      fail_field(file, field, expected, text);
    }
  }
  return out;
}

void check_regular_file(const std::string& path, const std::string& role) {
  namespace fs = std::filesystem;
  const std::string what = role.empty() ? "" : role + " ";
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (ec || !fs::exists(st)) fail(path, what + "file not found (expected an existing file)");
  if (fs::is_directory(st)) fail(path, "is a directory, expected a " + (role.empty() ? "volume" : role) + " file");
  if (!fs::is_regular_file(st)) fail(path, "is not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open for reading (permission denied?)");
}

uint64_t file_size_of(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  if (ec) fail(path, "cannot read the file size: " + ec.message());
  return n;
}

std::string read_file_range(const std::string& path, uint64_t offset, uint64_t max_bytes) {
  const uint64_t size = file_size_of(path);
  if (offset >= size) return {};
  const uint64_t n = std::min(max_bytes, size - offset);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open for reading");
  in.seekg(std::streamoff(offset));
  std::string out(n, '\0');
  in.read(out.data(), std::streamsize(n));
  if (uint64_t(in.gcount()) != n) fail(path, "read error");
  return out;
}

std::string sibling_path(const std::string& header_path, const std::string& name) {
  const std::filesystem::path p(name);
  if (p.is_absolute()) return name;
  return (std::filesystem::path(header_path).parent_path() / p).string();
}

std::string format_double(double v) {
  char buf[64];
  const auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, p) : std::to_string(v);
}

// Built with += : GCC 12 warns falsely (stringop-overflow) on "literal" + std::string temporaries.
std::string format_vector(double x, double y, double z) {
  std::string out = "(";
  out += format_double(x);
  out += ',';
  out += format_double(y);
  out += ',';
  out += format_double(z);
  out += ')';
  return out;
}

}  // namespace cpmesh::io
