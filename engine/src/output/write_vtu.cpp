// Result files for ParaView: VTK XML UnstructuredGrid (.vtu, version 1.0, UInt64 headers,
// little-endian) with tetrahedra and point/cell fields, and .pvd collections that index them
// by time. Files are written to "<path>.tmp" and renamed, so that a viewer polling the output
// folder during a run never opens half a file.
//
// Inline data encodings (format attribute of each DataArray):
//  - ascii: shortest round-trip decimal text (std::to_chars), so values read back bit-exactly;
//  - binary: base64 of [UInt64 byte count][raw little-endian data], as one base64 stream;
//  - binary + vtkZLibDataCompressor: the data is cut into 32 KiB blocks, each zlib-compressed;
//    base64(header) followed by base64(all compressed blocks), the header being the UInt64
//    words [block count, block size, last block size (0 when the last block is full),
//    compressed size of each block] (vtkXMLWriter::CreateCompressionHeader).
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string_view>
#include <string>
#include <system_error>
#include <type_traits>
#include <vector>

#include "base64.hpp"
#include "pliant/error.hpp"
#include "pliant/vtu_writer.hpp"

namespace pliant {
namespace {

using detail::base64_append;

static_assert(std::endian::native == std::endian::little,
              "the VTU writer emits raw little-endian data; a big-endian host needs byte swaps");

constexpr std::size_t kZlibBlockBytes = 32768;  // VTK's default compression block size
constexpr std::uint8_t kVtkTetra = 10;

// Text safe inside a double-quoted XML attribute.
std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// Shortest text that parses back to exactly the same value.
template <class T>
void append_number(std::string& out, T v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

template <class T> constexpr const char* vtk_type_name();
template <> constexpr const char* vtk_type_name<double>() { return "Float64"; }
template <> constexpr const char* vtk_type_name<std::int32_t>() { return "Int32"; }
template <> constexpr const char* vtk_type_name<std::int64_t>() { return "Int64"; }
template <> constexpr const char* vtk_type_name<std::uint8_t>() { return "UInt8"; }

// base64 of the zlib block header then base64 of the concatenated compressed blocks.
void append_zlib_base64(const unsigned char* bytes, std::size_t size, std::string& out) {
  const std::size_t blocks = (size + kZlibBlockBytes - 1) / kZlibBlockBytes;
  std::vector<std::uint64_t> header(3 + blocks);
  header[0] = blocks;
  header[1] = kZlibBlockBytes;
  header[2] = size % kZlibBlockBytes;
  std::vector<unsigned char> packed;
  packed.reserve(compressBound(static_cast<uLong>(std::min(size, kZlibBlockBytes))) * blocks);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t begin = b * kZlibBlockBytes;
    const std::size_t len = std::min(kZlibBlockBytes, size - begin);
    uLongf packed_len = compressBound(static_cast<uLong>(len));
    const std::size_t at = packed.size();
    packed.resize(at + packed_len);
    // Z_BEST_SPEED: frames are written during a run; speed matters more than the last 10 %.
    if (compress2(packed.data() + at, &packed_len, bytes + begin, static_cast<uLong>(len),
                  Z_BEST_SPEED) != Z_OK)
      throw InputError("zlib compression failed");
    packed.resize(at + packed_len);
    header[3 + b] = packed_len;
  }
  base64_append(header.data(), header.size() * sizeof(std::uint64_t), out);
  base64_append(packed.data(), packed.size(), out);
}

// One <DataArray> element with its values, in the requested encoding.
template <class T>
void append_data_array(std::string& out, std::string_view name, int components, const T* v,
                       std::size_t n, VtuEncoding enc) {
  out += "        <DataArray type=\"";
  out += vtk_type_name<T>();
  out += "\" Name=\"";
  out += xml_escape(name);
  out += "\" NumberOfComponents=\"";
  append_number(out, components);
  out += enc == VtuEncoding::ascii ? "\" format=\"ascii\">\n" : "\" format=\"binary\">\n";
  const std::size_t bytes = n * sizeof(T);
  switch (enc) {
    case VtuEncoding::ascii:
      for (std::size_t i = 0; i < n; ++i) {
        if constexpr (std::is_same_v<T, std::uint8_t>) append_number(out, unsigned{v[i]});
        else append_number(out, v[i]);
        out += (i + 1) % 12 == 0 || i + 1 == n ? '\n' : ' ';
      }
      break;
    case VtuEncoding::base64: {
      std::vector<unsigned char> buf(sizeof(std::uint64_t) + bytes);
      const std::uint64_t len = bytes;
      std::memcpy(buf.data(), &len, sizeof len);
      if (bytes) std::memcpy(buf.data() + sizeof len, v, bytes);
      base64_append(buf.data(), buf.size(), out);
      out += '\n';
      break;
    }
    case VtuEncoding::base64_zlib:
      append_zlib_base64(reinterpret_cast<const unsigned char*>(v), bytes, out);
      out += '\n';
      break;
  }
  out += "        </DataArray>\n";
}

// Writes `text` to `path` through "<path>.tmp" and a rename (atomic on POSIX file systems).
void write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  {
    std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
    if (!os) throw InputError("cannot open '" + tmp.string() + "' for writing (output '" +
                              path.string() + "')");
    os.write(text.data(), static_cast<std::streamsize>(text.size()));
    os.close();
    if (!os) {
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw InputError("cannot write '" + path.string() + "' (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw InputError("cannot rename '" + tmp.string() + "' to '" + path.string() +
                     "': " + ec.message());
  }
}

}  // namespace

void write_vtu(const std::filesystem::path& path, std::span<const double> points_xyz,
               std::span<const Tet> tets, const std::vector<VtuField>& fields,
               VtuEncoding encoding) {
  std::string where = "'";  // built by appends: GCC 12 -O3 warns (-Wrestrict) on "'" + string&&
  where += path.string();
  where += '\'';
  if (points_xyz.size() % 3 != 0)
    throw InputError("VTU " + where + ": point coordinates are not a multiple of 3");
  const std::size_t np = points_xyz.size() / 3, nc = tets.size();
  for (std::size_t c = 0; c < nc; ++c)
    for (std::int32_t v : tets[c])
      if (v < 0 || static_cast<std::size_t>(v) >= np)
        throw InputError("VTU " + where + ": cell " + std::to_string(c) + " has vertex index " +
                         std::to_string(v) + " out of range [0, " + std::to_string(np) + ")");
  for (const VtuField& f : fields) {
    const std::size_t count = f.per_cell ? nc : np;
    if (f.components < 1 || f.values.size() != count * static_cast<std::size_t>(f.components))
      throw InputError("VTU " + where + ": field '" + f.name + "' has " +
                       std::to_string(f.values.size()) + " values for " + std::to_string(count) +
                       (f.per_cell ? " cells" : " points") + " x " +
                       std::to_string(f.components) + " components");
  }

  std::string out;
  out += "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
         "byte_order=\"LittleEndian\" header_type=\"UInt64\"";
  if (encoding == VtuEncoding::base64_zlib) out += " compressor=\"vtkZLibDataCompressor\"";
  out += ">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"";
  append_number(out, np);
  out += "\" NumberOfCells=\"";
  append_number(out, nc);
  out += "\">\n";

  for (bool per_cell : {false, true}) {
    out += per_cell ? "      <CellData>\n" : "      <PointData>\n";
    for (const VtuField& f : fields)
      if (f.per_cell == per_cell)
        append_data_array(out, f.name, f.components, f.values.data(), f.values.size(), encoding);
    out += per_cell ? "      </CellData>\n" : "      </PointData>\n";
  }

  out += "      <Points>\n";
  append_data_array(out, "Points", 3, points_xyz.data(), points_xyz.size(), encoding);
  out += "      </Points>\n      <Cells>\n";
  append_data_array(out, "connectivity", 1, tets.empty() ? nullptr : tets[0].data(), 4 * nc,
                    encoding);
  // Offsets are end positions in connectivity: 4, 8, ...; 64-bit once they leave Int32.
  if (4 * nc <= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    std::vector<std::int32_t> offsets(nc);
    for (std::size_t c = 0; c < nc; ++c) offsets[c] = static_cast<std::int32_t>(4 * (c + 1));
    append_data_array(out, "offsets", 1, offsets.data(), nc, encoding);
  } else {
    std::vector<std::int64_t> offsets(nc);
    for (std::size_t c = 0; c < nc; ++c) offsets[c] = static_cast<std::int64_t>(4 * (c + 1));
    append_data_array(out, "offsets", 1, offsets.data(), nc, encoding);
  }
  const std::vector<std::uint8_t> types(nc, kVtkTetra);
  append_data_array(out, "types", 1, types.data(), nc, encoding);
  out += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";

  write_file_atomically(path, out);
}

PvdSeries::PvdSeries(std::filesystem::path pvd_path) : path_(std::move(pvd_path)) {}

void PvdSeries::add(double time, const std::string& relative_file, int part) {
  entries_.push_back({time, part, relative_file});
}

void PvdSeries::write() const {
  std::string out =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
      "  <Collection>\n";
  for (const Entry& e : entries_) {
    out += "    <DataSet timestep=\"";
    append_number(out, e.time);  // s
    out += "\" group=\"\" part=\"";
    append_number(out, e.part);
    out += "\" file=\"";
    out += xml_escape(e.file);
    out += "\"/>\n";
  }
  out += "  </Collection>\n</VTKFile>\n";
  write_file_atomically(path_, out);
}

}  // namespace pliant
