// Shared by the reader harnesses: the readers take a path (they check it is a regular file and
// read it whole), so each input is written to a file of this process in /dev/shm (RAM; /tmp when
// there is none) and read back through the public reader. The files are reused by every input of
// the run and removed at exit. Not part of the engine: built only with -DPLIANT_FUZZ=ON.
#pragma once
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace pliant::fuzz {

// A folder private to this process (libFuzzer's -jobs/-workers run several at once).
inline const std::filesystem::path& work_dir() {
  static const std::filesystem::path dir = [] {
    std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    auto d = base / ("pliant-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    static const std::string to_remove = d.string();
    std::atexit([] { std::error_code ec; std::filesystem::remove_all(to_remove, ec); });
    return d;
  }();
  return dir;
}

// Writes `bytes` to work_dir()/name and returns the path.
inline std::filesystem::path write_file(const std::string& name, std::string_view bytes) {
  auto p = work_dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) std::abort();  // the harness itself failed, not the reader
  return p;
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace pliant::fuzz
