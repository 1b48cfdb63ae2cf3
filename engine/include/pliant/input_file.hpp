// The one way pliant opens a file a user named for reading: mesh files, surfaces, scenes,
// result files for `pliant render`, reference files, the .pvd next to a .vtu. Only regular files
// are read (symbolic links are followed): a FIFO named .msh blocked `pliant info` forever and a
// link to /dev/zero was read until memory ran out. Errors are InputError naming the path.
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace pliant {

// The whole file as bytes. `what` names the file's role in messages ("mesh file", "scene file").
// Throws InputError "<path>: cannot open <what> (No such file or directory)", "<path>: is a
// directory, not a <what>", "<path>: is a FIFO (named pipe), not a regular file", ... . What is
// not a regular file is refused without being opened; a regular file is opened without blocking
// and checked again on the open descriptor, so nothing can be swapped in between.
std::string read_input_file(const std::filesystem::path& path, std::string_view what);

// The same check without reading, for readers that open the file themselves (CGAL's surface
// readers, a sniff of the first bytes): throws as read_input_file, else returns the size (bytes).
std::uintmax_t check_input_file(const std::filesystem::path& path, std::string_view what);

}  // namespace pliant
