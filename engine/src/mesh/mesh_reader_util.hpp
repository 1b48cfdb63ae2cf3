// Private helpers shared by the mesh readers (not installed, not part of the API): reading a
// whole file with clear errors, a line cursor that counts lines from 1, checked number
// parsing (std::from_chars, whole token or nothing), and the variant of finalize_tet_mesh
// that lets a reader name a tet the way its file does ("57: element 12" rather than "cell 3").
#pragma once
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant::meshio {

[[noreturn]] void fail(const std::string& message);  // throws InputError(message)

// The whole file as bytes, through read_input_file (regular files only). Throws
// "<path>: cannot open mesh file (...)", "<path>: is a FIFO ...", or "<path>: file is empty".
std::string read_file(const std::filesystem::path& path);

std::string_view trim(std::string_view s);
std::vector<std::string_view> split(std::string_view s);  // on blanks (space, tab, CR, ...)
bool iequals(std::string_view a, std::string_view b);      // ASCII case-insensitive
bool starts_with_nocase(std::string_view s, std::string_view prefix);

// Whole-token parses; false on anything else (empty, trailing junk, overflow). parse_double
// accepts a leading '+' and lets "nan"/"inf" through so that the caller can name them.
bool parse_int(std::string_view token, long long& out);
bool parse_double(std::string_view token, double& out);

// A count read from a file (points, cells, values, components) against the file's size, before
// anything is multiplied or allocated with it: at most `per_byte` items per byte of the file (1 for
// text, where each counted item takes at least a byte; about 1100 for zlib-compressed data, whose
// ratio is at most 1032:1). Throws "<where>: <what> is more than the file (<bytes> bytes) can
// hold" (what: e.g. `NumberOfPoints="..."`, "the number of nodes 8"). Counts that pass multiply
// without overflow for any file below 2^40 bytes.
void check_count(long long n, std::size_t file_bytes, long long per_byte, const std::string& where,
                 const std::string& what);
// The largest count check_count accepts.
long long count_limit(std::size_t file_bytes, long long per_byte);

// 1-based line number of byte `offset` in `text` (for messages only: it counts, so it is O(n)).
std::size_t line_of(std::string_view text, std::size_t offset);

// Walks a text line by line; line() has no end-of-line characters.
class LineCursor {
 public:
  explicit LineCursor(std::string_view text) : text_(text) {}
  bool next();                       // false at the end of the text
  std::string_view line() const { return line_; }
  std::size_t number() const { return number_; }  // 1-based, of the current line
 private:
  std::string_view text_, line_;
  std::size_t pos_ = 0, number_ = 0;
};

// finalize_tet_mesh, but a failing tet i is named "<source><where(i)>: ..." where where(i) is
// e.g. ":57: element 12" or ": cell 3".
void finalize_tet_mesh_named(TetMesh& mesh, const std::string& source, MeshLoadReport& report,
                             const std::function<std::string(std::size_t)>& where);

}  // namespace pliant::meshio
