#pragma once
// Small text helpers shared by the text-header parsers (NRRD, MetaImage, INRIMAGE) and the file access they all need.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cpmesh::io {

std::string trim(std::string_view s);
std::vector<std::string> split_words(std::string_view s);
std::string to_lower(std::string_view s);
bool ends_with(std::string_view s, std::string_view suffix);

// Strict number parsing: the whole (trimmed) text must be the number. Errors name `file` and `field`.
int64_t parse_int(const std::string& file, const std::string& field, const std::string& text);
double parse_double(const std::string& file, const std::string& field, const std::string& text);
// Exactly `n` whitespace- (or comma-) separated numbers.
std::vector<int64_t> parse_ints(const std::string& file, const std::string& field, const std::string& text, size_t n,
                                const std::string& expected);
std::vector<double> parse_doubles(const std::string& file, const std::string& field, const std::string& text, size_t n,
                                  const std::string& expected);

// Files: a missing path, a directory or an unreadable file throws Error naming `path`.
void check_regular_file(const std::string& path, const std::string& role = "");
uint64_t file_size_of(const std::string& path);
std::string read_file_range(const std::string& path, uint64_t offset, uint64_t max_bytes);
// A data file named in a header, relative to the header's directory unless absolute.
std::string sibling_path(const std::string& header_path, const std::string& name);

std::string format_double(double v);  // shortest text that reads back to the same double
std::string format_vector(double x, double y, double z);  // "(x,y,z)"

}  // namespace cpmesh::io
