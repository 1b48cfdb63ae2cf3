// A skin: a high-resolution render surface bound to a body's simulated mesh (thesis ch. 6; DESIGN.md
// §7). Each skin vertex is tied to the nearest boundary triangle of each level of the body at rest
// (barycentric weights of the nearest point, and the offset to the vertex in the triangle's own
// frame: two tangential components and one along the normal), and follows that triangle as the
// body deforms. BodyDef::skin names an OBJ file in the units and frame of the body's mesh (the
// mesh's scale and translate are applied to it too). Pictures draw it instead of the tet boundary.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace pliant {

// A triangle surface read from a file: interleaved points (x, y, z) and triangles.
struct SkinSurface {
  std::vector<double> points;
  std::vector<std::array<std::int32_t, 3>> triangles;
  std::size_t point_count() const { return points.size() / 3; }
};

// Reads the vertices ("v x y z") and faces ("f a b c ...", with a/b/c index forms and negative
// indices; polygons are split into a fan of triangles) of an OBJ file; other lines are ignored.
// Throws InputError naming the file and line for a bad number, an index out of range or a face
// of fewer than 3 vertices, and for a file without faces.
SkinSurface read_obj_surface(const std::filesystem::path& path);

}  // namespace pliant
