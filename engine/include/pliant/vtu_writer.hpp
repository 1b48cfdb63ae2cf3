// VTK XML UnstructuredGrid (.vtu) files and ParaView .pvd series, for results.
#pragma once
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {

struct VtuField {
  std::string name;
  int components = 1;           // 1 (scalar) or 3 (vector) or 9 (tensor)
  bool per_cell = false;        // false: PointData, true: CellData
  std::vector<double> values;   // components * (points or cells), interleaved
};

enum class VtuEncoding { ascii, base64, base64_zlib };

// Writes `points_xyz` (3 per point) and `tets` as VTK_TETRA cells with the given fields.
// Throws InputError if the file cannot be written or a field has the wrong size.
void write_vtu(const std::filesystem::path& path, std::span<const double> points_xyz,
               std::span<const Tet> tets, const std::vector<VtuField>& fields,
               VtuEncoding encoding = VtuEncoding::base64);

// A .pvd collection: one (time, file) entry per frame, file names relative to the .pvd.
class PvdSeries {
 public:
  explicit PvdSeries(std::filesystem::path pvd_path);
  void add(double time, const std::string& relative_file, int part = 0);
  void write() const;  // rewrites the whole .pvd (cheap; keeps a valid file after each frame)
 private:
  struct Entry { double time; int part; std::string file; };
  std::filesystem::path path_;
  std::vector<Entry> entries_;
};

}  // namespace pliant
