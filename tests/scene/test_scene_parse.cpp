// Scene files -> SceneDef: the documented example, defaults, every validation rule (each error
// must name the exact field path), comment keys, relative mesh paths, and PATH=VALUE overrides.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <string>

#include "../support/special_files.hpp"
#include "pliant/error.hpp"
#include "pliant/scene.hpp"

namespace fs = std::filesystem;
using namespace pliant;

namespace {

// A fresh folder with a few empty mesh files, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    dir_ = fs::temp_directory_path() /
           ("pliant_scene_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(dir_ / "meshes");
    for (const char* f : {"meshes/liver.msh", "meshes/skin.obj", "beam.vtu"}) write(f, "");
  }
  ~TempDir() { fs::remove_all(dir_); }
  const fs::path& path() const { return dir_; }
  fs::path write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name, std::ios::binary) << text;
    return dir_ / name;
  }

 private:
  fs::path dir_;
};

// The message of the InputError that parsing `json` throws ("" if none).
std::string error_of(const std::string& json, const fs::path& base = fs::temp_directory_path()) {
  try {
    parse_scene(json, "t.json", base);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const char* kFullExample = R"({
  "_comment": "a beam clamped at x=0, pulled at its tip",
  "duration": 2.5,
  "gravity": [0, 0, -1.62],
  "precision": "float",
  "threads": 4,
  "time_step": {"dt": 0.001, "courant": 0.4, "substep": true},
  "bodies": [
    {
      "name": "beam",
      "mesh": {"box": {"min": [0, 0, 0], "max": [1, 0.1, 0.2], "cells": [40, 4, 8], "tets_per_cell": 5},
               "scale": 2, "translate": [1, 2, 3]},
      "material": {"young": 2e6, "poisson": 0.45, "density": 1100,
                   "damping": {"mass": 0.1, "stiffness": 0.01, "bulk_viscosity": 5, "shear_viscosity": 3}},
      "model": "stvk",
      "fixed": [{"box": {"min": [0, 0, 0], "max": [0, 0.1, 0.2]}}],
      "prescribed": [{"region": {"sphere": {"center": [1, 0.05, 0.1], "radius": 0.02}},
                      "keyframes": [{"time": 0, "offset": [0, 0, 0]}, {"time": 1, "offset": [0, 0, -0.01]}]}],
      "loads": [{"region": {"nodes": [3, 7, 11]}, "force": [0, 0, -1]}]
    },
    {"name": "liver", "mesh": {"file": "meshes/liver.msh"}, "model": "linear"},
    {"mesh": {"surface": "meshes/skin.obj", "cell_size": 0.01}},
    {"name": "organ", "mesh": {"implicit": "organ", "cell_size": 0.005}, "model": "springs"}
  ],
  "probes": [{"name": "tip", "body": "beam", "point": [1, 0.05, 0.05]}],
  "output": {"vtu_every": 0.05, "probe_every": 0.01}
})";

}  // namespace

TEST(SceneParse, FullExample) {
  TempDir tmp;
  const SceneDef s = parse_scene(kFullExample, "full.json", tmp.path());
  EXPECT_EQ(s.source, "full.json");
  EXPECT_DOUBLE_EQ(s.duration, 2.5);
  EXPECT_EQ(s.world.gravity, (Vec3d{0, 0, -1.62}));
  EXPECT_EQ(s.world.precision, Precision::float32);
  EXPECT_EQ(s.world.threads, 4);
  ASSERT_TRUE(s.world.time_step.dt.has_value());
  EXPECT_DOUBLE_EQ(*s.world.time_step.dt, 0.001);
  EXPECT_DOUBLE_EQ(s.world.time_step.courant, 0.4);
  EXPECT_TRUE(s.world.time_step.substep);

  ASSERT_EQ(s.bodies.size(), 4u);
  const BodyDef& b = s.bodies[0];
  EXPECT_EQ(b.name, "beam");
  EXPECT_EQ(b.mesh.kind, MeshSourceDef::Kind::box);
  EXPECT_EQ(b.mesh.max, (Vec3d{1, 0.1, 0.2}));
  EXPECT_EQ(b.mesh.cells, (std::array<int, 3>{40, 4, 8}));
  EXPECT_EQ(b.mesh.tets_per_cell, 5);
  EXPECT_DOUBLE_EQ(b.mesh.scale, 2);
  EXPECT_EQ(b.mesh.translate, (Vec3d{1, 2, 3}));
  EXPECT_DOUBLE_EQ(b.material.young, 2e6);
  EXPECT_DOUBLE_EQ(b.material.poisson, 0.45);
  EXPECT_DOUBLE_EQ(b.material.density, 1100);
  EXPECT_DOUBLE_EQ(b.material.damping.mass, 0.1);
  EXPECT_DOUBLE_EQ(b.material.damping.stiffness, 0.01);
  EXPECT_EQ(b.material.damping.bulk_viscosity, 5.0);
  EXPECT_EQ(b.material.damping.shear_viscosity, 3.0);
  EXPECT_EQ(b.model, ForceModel::stvk);
  ASSERT_EQ(b.fixed.size(), 1u);
  EXPECT_EQ(b.fixed[0].kind, RegionDef::Kind::box);
  EXPECT_EQ(b.fixed[0].max, (Vec3d{0, 0.1, 0.2}));
  ASSERT_EQ(b.prescribed.size(), 1u);
  EXPECT_EQ(b.prescribed[0].region.kind, RegionDef::Kind::sphere);
  EXPECT_DOUBLE_EQ(b.prescribed[0].region.radius, 0.02);
  ASSERT_EQ(b.prescribed[0].keyframes.size(), 2u);
  EXPECT_DOUBLE_EQ(b.prescribed[0].keyframes[1].time, 1);
  EXPECT_EQ(b.prescribed[0].keyframes[1].offset, (Vec3d{0, 0, -0.01}));
  ASSERT_EQ(b.loads.size(), 1u);
  EXPECT_EQ(b.loads[0].region.kind, RegionDef::Kind::nodes);
  EXPECT_EQ(b.loads[0].region.nodes, (std::vector<std::int32_t>{3, 7, 11}));
  EXPECT_EQ(b.loads[0].total_force, (Vec3d{0, 0, -1}));

  EXPECT_EQ(s.bodies[1].mesh.kind, MeshSourceDef::Kind::file);
  EXPECT_EQ(s.bodies[1].mesh.path, fs::absolute(tmp.path() / "meshes/liver.msh").lexically_normal());
  EXPECT_EQ(s.bodies[1].model, ForceModel::linear);
  EXPECT_EQ(s.bodies[2].name, "body2");
  EXPECT_EQ(s.bodies[2].mesh.kind, MeshSourceDef::Kind::surface);
  EXPECT_DOUBLE_EQ(s.bodies[2].mesh.cell_size, 0.01);
  EXPECT_EQ(s.bodies[3].mesh.kind, MeshSourceDef::Kind::implicit);
  EXPECT_EQ(s.bodies[3].mesh.shape, "organ");
  EXPECT_EQ(s.bodies[3].model, ForceModel::springs);

  ASSERT_EQ(s.probes.size(), 1u);
  EXPECT_EQ(s.probes[0].name, "tip");
  EXPECT_EQ(s.probes[0].body, "beam");
  EXPECT_EQ(s.probes[0].point, (Vec3d{1, 0.05, 0.05}));
  EXPECT_DOUBLE_EQ(s.output.vtu_every, 0.05);
  EXPECT_DOUBLE_EQ(s.output.probe_every, 0.01);
}

// Boxes: 5 tets per cell unless the scene says otherwise, 6 for a multiresolution body (its box
// levels nest exactly only with Kuhn cells); an explicit value always wins (issue 11 §5).
TEST(SceneParse, TetsPerCellDefaultsToFiveButSixForMultiresolution) {
  auto tpc = [](const std::string& body) {
    return parse_scene(R"({"bodies": [)" + body + "]}", "t.json", "").bodies.at(0).mesh.tets_per_cell;
  };
  EXPECT_EQ(tpc(R"({"mesh": {"box": {"cells": [4, 2, 2]}}})"), 5);
  EXPECT_EQ(tpc(R"({"mesh": {"box": {"cells": [4, 2, 2], "tets_per_cell": 6}}})"), 6);
  EXPECT_EQ(tpc(R"({"mesh": {"box": {"cells": [4, 2, 2]}}, "multiresolution": {"levels": 2}})"), 6);
  EXPECT_EQ(tpc(R"({"mesh": {"box": {"cells": [4, 2, 2], "tets_per_cell": 5}}, "multiresolution": {"levels": 2}})"), 5);
}

TEST(SceneParse, DefaultsWhenKeysAbsent) {
  const SceneDef s = parse_scene(R"({"bodies": [{"mesh": {"box": {}}}]})", "d.json", "");
  const SceneDef d;
  const BodyDef db;
  EXPECT_EQ(s.duration, d.duration);
  EXPECT_EQ(s.world.gravity, d.world.gravity);
  EXPECT_EQ(s.world.precision, Precision::float64);
  EXPECT_EQ(s.world.threads, 0);
  EXPECT_EQ(s.world.packed_corners, PackedCorners::automatic);
  EXPECT_FALSE(s.world.time_step.dt.has_value());
  EXPECT_EQ(s.world.time_step.courant, 0.5);
  EXPECT_FALSE(s.world.time_step.substep);
  ASSERT_EQ(s.bodies.size(), 1u);
  const BodyDef& b = s.bodies[0];
  EXPECT_EQ(b.name, "body0");
  EXPECT_EQ(b.mesh.min, db.mesh.min);
  EXPECT_EQ(b.mesh.max, db.mesh.max);
  EXPECT_EQ(b.mesh.cells, db.mesh.cells);
  EXPECT_EQ(b.mesh.tets_per_cell, 5);  // a scene's box: 5 tets per cell unless it says otherwise
  EXPECT_EQ(b.mesh.scale, 1.0);
  EXPECT_EQ(b.material.young, db.material.young);
  EXPECT_EQ(b.material.poisson, db.material.poisson);
  EXPECT_EQ(b.material.density, db.material.density);
  EXPECT_FALSE(b.material.damping.bulk_viscosity.has_value());
  EXPECT_EQ(b.model, ForceModel::corotational);
  EXPECT_TRUE(b.fixed.empty() && b.prescribed.empty() && b.loads.empty());
  EXPECT_TRUE(s.probes.empty());
  EXPECT_EQ(s.output.vtu_every, 0);
  EXPECT_EQ(s.output.probe_every, 0);
}

TEST(SceneParse, PackedCornersAutoOnOrOff) {
  auto packed = [](const char* v) {
    return parse_scene(std::string(R"({"packed_corners": )") + v + R"(, "bodies": [{"mesh": {"box": {}}}]})", "p.json", "")
        .world.packed_corners;
  };
  EXPECT_EQ(packed(R"("auto")"), PackedCorners::automatic);
  EXPECT_EQ(packed(R"("on")"), PackedCorners::on);
  EXPECT_EQ(packed(R"("off")"), PackedCorners::off);
  EXPECT_THROW(packed("true"), InputError);
}

TEST(SceneParse, DtAutoOrNumber) {
  auto dt = [](const std::string& v) {
    return parse_scene(R"({"time_step": {"dt": )" + v + R"(}, "bodies": [{"mesh": {"box": {}}}]})",
                       "t.json", "")
        .world.time_step.dt;
  };
  EXPECT_FALSE(dt(R"("auto")").has_value());
  ASSERT_TRUE(dt("0.002").has_value());
  EXPECT_DOUBLE_EQ(*dt("0.002"), 0.002);
  EXPECT_THROW(dt(R"("fast")"), InputError);
  EXPECT_THROW(dt("0"), InputError);
}

TEST(SceneParse, CommentKeysIgnored) {
  const SceneDef s = parse_scene(R"({"_about": {"anything": [1, 2]}, "//": "note",
      "bodies": [{"// why": "soft", "mesh": {"_x": 1, "box": {"_y": true}},
                  "material": {"//young": "was 1e5", "young": 5e5}}]})",
                                 "c.json", "");
  EXPECT_EQ(s.bodies[0].material.young, 5e5);
}

TEST(SceneParse, UnknownKeyListsKnownKeys) {
  const std::string e = error_of(R"({"bodies": [{"mesh": {"box": {}}, "materail": {}}]})");
  EXPECT_NE(e.find("t.json: bodies[0].materail: unknown key; known keys: name, mesh, material, "
                   "model, fixed, prescribed, loads"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("did you mean \"material\""), std::string::npos) << e;
}

// ---- each rule, violated: the message names the exact field path ----

struct Violation {
  const char* what;
  const char* json;
  const char* path;  // expected "t.json: <path>: " in the message
};

void PrintTo(const Violation& v, std::ostream* os) { *os << v.what; }

class SceneViolation : public ::testing::TestWithParam<Violation> {};

TEST_P(SceneViolation, NamesFieldPath) {
  const Violation& v = GetParam();
  const std::string e = error_of(v.json);
  ASSERT_FALSE(e.empty()) << v.what << ": no error";
  EXPECT_NE(e.find(std::string("t.json: ") + v.path + ": "), std::string::npos)
      << v.what << ": " << e;
}

#define BODY(b) "{\"bodies\": [" b "]}"
#define BOX_BODY(extra) BODY("{\"mesh\": {\"box\": {}}" extra "}")
const Violation kViolations[] = {
    {"poisson 0.5", BOX_BODY(R"(, "material": {"poisson": 0.5})"), "bodies[0].material.poisson"},
    {"negative young", BOX_BODY(R"(, "material": {"young": -1})"), "bodies[0].material.young"},
    {"zero density", BOX_BODY(R"(, "material": {"density": 0})"), "bodies[0].material.density"},
    {"negative damping", BOX_BODY(R"(, "material": {"damping": {"shear_viscosity": -1}})"),
     "bodies[0].material.damping.shear_viscosity"},
    {"unknown key", BOX_BODY(R"(, "materail": {})"), "bodies[0].materail"},
    {"unknown top key", R"({"bodies": [{"mesh": {"box": {}}}], "gravitty": [0,0,0]})", "gravitty"},
    {"wrong type", BOX_BODY(R"(, "material": {"young": "soft"})"), "bodies[0].material.young"},
    {"wrong type array", R"({"bodies": {"mesh": {}}})", "bodies"},
    {"box min > max", BODY(R"({"mesh": {"box": {"min": [0,0,0], "max": [1,-1,1]}}})"), "bodies[0].mesh.box.max"},
    {"cells 0", BODY(R"({"mesh": {"box": {"cells": [4,0,4]}}})"), "bodies[0].mesh.box.cells[1]"},
    {"cells not integer", BODY(R"({"mesh": {"box": {"cells": [4,2.5,4]}}})"), "bodies[0].mesh.box.cells[1]"},
    {"too many cells", BODY(R"({"mesh": {"box": {"cells": [1000,1000,1000]}}})"), "bodies[0].mesh.box.cells"},
    {"tets_per_cell 7", BODY(R"({"mesh": {"box": {"tets_per_cell": 7}}})"), "bodies[0].mesh.box.tets_per_cell"},
    {"unknown model", BOX_BODY(R"(, "model": "neohookean")"), "bodies[0].model"},
    {"unknown precision", R"({"precision": "half", "bodies": [{"mesh": {"box": {}}}]})", "precision"},
    {"unknown packed_corners", R"({"packed_corners": "sometimes", "bodies": [{"mesh": {"box": {}}}]})", "packed_corners"},
    {"probe unknown body",
     R"({"bodies": [{"name": "beam", "mesh": {"box": {}}}], "probes": [{"body": "bem", "point": [0,0,0]}]})",
     "probes[0].body"},
    {"duplicate probe names",
     R"({"bodies": [{"mesh": {"box": {}}}], "probes": [{"name": "p", "body": "body0", "point": [0,0,0]},
        {"name": "p", "body": "body0", "point": [0,0,0]}]})",
     "probes[1].name"},
    {"duplicate body names", BODY(R"({"name": "a", "mesh": {"box": {}}}, {"name": "a", "mesh": {"box": {}}})"),
     "bodies[1].name"},
    {"empty body name", BODY(R"({"name": "", "mesh": {"box": {}}})"), "bodies[0].name"},
    {"mesh with two kinds", BODY(R"({"mesh": {"box": {}, "implicit": "organ", "cell_size": 0.1}})"), "bodies[0].mesh"},
    {"missing mesh", BODY(R"({"name": "a"})"), "bodies[0].mesh"},
    {"no bodies", R"({"bodies": []})", "bodies"},
    {"missing bodies", R"({"duration": 1})", "bodies"},
    {"keyframes out of order",
     BOX_BODY(R"(, "prescribed": [{"region": {"nodes": [0]}, "keyframes": [{"time": 1, "offset": [0,0,0]},
        {"time": 0.5, "offset": [0,0,0]}]}])"),
     "bodies[0].prescribed[0].keyframes[1].time"},
    {"no keyframes", BOX_BODY(R"(, "prescribed": [{"region": {"nodes": [0]}, "keyframes": []}])"),
     "bodies[0].prescribed[0].keyframes"},
    {"sphere radius 0", BOX_BODY(R"(, "fixed": [{"sphere": {"center": [0,0,0], "radius": 0}}])"),
     "bodies[0].fixed[0].sphere.radius"},
    {"negative node", BOX_BODY(R"(, "loads": [{"region": {"nodes": [1, -2]}, "force": [0,0,1]}])"),
     "bodies[0].loads[0].region.nodes[1]"},
    {"region box min > max", BOX_BODY(R"(, "fixed": [{"box": {"min": [0,0,1], "max": [1,1,0]}}])"),
     "bodies[0].fixed[0].box.max"},
    {"gravity 2 numbers", R"({"gravity": [0, -9.81], "bodies": [{"mesh": {"box": {}}}]})", "gravity"},
    {"courant 0", R"({"time_step": {"courant": 0}, "bodies": [{"mesh": {"box": {}}}]})", "time_step.courant"},
    {"courant above 1", R"({"time_step": {"courant": 1.5}, "bodies": [{"mesh": {"box": {}}}]})", "time_step.courant"},
    {"substep not bool", R"({"time_step": {"substep": 1}, "bodies": [{"mesh": {"box": {}}}]})", "time_step.substep"},
    {"negative threads", R"({"threads": -1, "bodies": [{"mesh": {"box": {}}}]})", "threads"},
    {"zero duration", R"({"duration": 0, "bodies": [{"mesh": {"box": {}}}]})", "duration"},
    {"negative output", R"({"output": {"vtu_every": -0.1}, "bodies": [{"mesh": {"box": {}}}]})", "output.vtu_every"},
    {"scale 0", BODY(R"({"mesh": {"box": {}, "scale": 0}})"), "bodies[0].mesh.scale"},
    {"cell_size missing", BODY(R"({"mesh": {"implicit": "organ"}})"), "bodies[0].mesh.cell_size"},
    {"cell_size on box", BODY(R"({"mesh": {"box": {}, "cell_size": 0.1}})"), "bodies[0].mesh.cell_size"},
    {"bad file extension", BODY(R"({"mesh": {"file": "beam.stl"}})"), "bodies[0].mesh.file"},
    {"missing mesh file", BODY(R"({"mesh": {"file": "no_such_mesh_4711.msh"}})"), "bodies[0].mesh.file"},
    {"missing surface file", BODY(R"({"mesh": {"surface": "no_such_4711.obj", "cell_size": 0.1}})"),
     "bodies[0].mesh.surface"},
    {"region with no kind", BOX_BODY(R"(, "fixed": [{}])"), "bodies[0].fixed[0]"},
    {"load missing force", BOX_BODY(R"(, "loads": [{"region": {"nodes": [0]}}])"), "bodies[0].loads[0].force"},
    {"duplicate key", R"({"bodies": [{"mesh": {"box": {}}, "model": "linear", "model": "stvk"}]})", "bodies[0].model"},
    {"top level not object", "[1, 2]", "top level"},
#define TOOL(t) "{\"bodies\": [{\"mesh\": {\"box\": {}}}], \"tools\": [" t "]}"
#define KEYS R"("path": {"keyframes": [{"time": 0, "position": [0,0,1]}]})"
    {"tool radius 0", TOOL(R"({"shape": {"sphere": {"radius": 0}}, )" KEYS "}"), "tools[0].shape.sphere.radius"},
    {"tool capsule no length", TOOL(R"({"shape": {"capsule": {"radius": 0.01}}, )" KEYS "}"), "tools[0].shape.capsule.length"},
    {"tool two shapes", TOOL(R"({"shape": {"sphere": {"radius": 1}, "capsule": {"radius": 1, "length": 1}}, )" KEYS "}"),
     "tools[0].shape"},
    {"tool unknown shape", TOOL(R"({"shape": {"cube": {}}, )" KEYS "}"), "tools[0].shape.cube"},
    {"tool no path", TOOL(R"({"shape": {"sphere": {"radius": 1}}})"), "tools[0].path"},
    {"tool no keyframes", TOOL(R"({"shape": {"sphere": {"radius": 1}}, "path": {"keyframes": []}})"), "tools[0].path.keyframes"},
    {"tool times not increasing",
     TOOL(R"({"shape": {"sphere": {"radius": 1}}, "path": {"keyframes": [{"time": 0, "position": [0,0,1]},
        {"time": 0, "position": [0,0,2]}]}})"),
     "tools[0].path.keyframes[1].time"},
    {"tool zero quaternion",
     TOOL(R"({"shape": {"sphere": {"radius": 1}}, "path": {"keyframes": [{"time": 0, "position": [0,0,1], "orientation": [0,0,0,0]}]}})"),
     "tools[0].path.keyframes[0].orientation"},
    {"tool unknown body", TOOL(R"({"shape": {"sphere": {"radius": 1}}, )" KEYS R"(, "bodies": ["liver"]})"), "tools[0].bodies[0]"},
    {"tool missing csv", TOOL(R"({"shape": {"sphere": {"radius": 1}}, "path": {"csv": "no_such_4711.csv"}})"), "tools[0].path.csv"},
    {"duplicate tool names", TOOL(R"({"name": "a", "shape": {"sphere": {"radius": 1}}, )" KEYS R"(}, {"name": "a", "shape": {"sphere": {"radius": 1}}, )" KEYS "}"),
     "tools[1].name"},
    {"tool unknown key", TOOL(R"({"shape": {"sphere": {"radius": 1}}, )" KEYS R"(, "colour": "red"})"), "tools[0].colour"},
#undef KEYS
#undef TOOL
};
#undef BOX_BODY
#undef BODY

INSTANTIATE_TEST_SUITE_P(Rules, SceneViolation, ::testing::ValuesIn(kViolations),
                         [](const auto& info) {
                           std::string n = info.param.what;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

TEST(SceneParse, ToolsFromKeyframesAndFromCsv) {
  TempDir dir;
  dir.write("path.csv", "# a tool path\nx,time,y,z,qw,qx,qy,qz\n0.1,0,0,1,1,0,0,0\n0.2,0.5,0,0.5,0,0,0,2\n");
  const SceneDef s = parse_scene(R"({"bodies": [{"name": "b", "mesh": {"box": {}}}],
    "tools": [{"name": "probe", "shape": {"capsule": {"radius": 0.01, "length": 0.1}},
               "path": {"keyframes": [{"time": 0, "position": [1, 2, 3]},
                                      {"time": 1, "position": [1, 2, 2], "orientation": [0, 1, 0, 0]}]},
               "bodies": ["b"]},
              {"shape": {"sphere": {"radius": 0.02}}, "path": {"csv": "path.csv"}}]})",
                                 "t.json", dir.path());
  ASSERT_EQ(s.tools.size(), 2u);
  const ToolDef& a = s.tools[0];
  EXPECT_EQ(a.name, "probe");
  EXPECT_EQ(a.shape.kind, ToolShapeDef::Kind::capsule);
  EXPECT_EQ(a.shape.radius, 0.01);
  EXPECT_EQ(a.shape.length, 0.1);
  ASSERT_EQ(a.keyframes.size(), 2u);
  EXPECT_EQ(a.keyframes[1].position, (Vec3d{1, 2, 2}));
  EXPECT_EQ(a.keyframes[1].orientation, (Quatd{0, 1, 0, 0}));
  EXPECT_EQ(a.keyframes[0].orientation, (Quatd{1, 0, 0, 0}));
  EXPECT_EQ(a.bodies, std::vector<std::string>{"b"});
  const ToolDef& b = s.tools[1];
  EXPECT_EQ(b.name, "tool1");
  EXPECT_EQ(b.shape.kind, ToolShapeDef::Kind::sphere);
  ASSERT_EQ(b.keyframes.size(), 2u);
  EXPECT_EQ(b.keyframes[1].time, 0.5);
  EXPECT_EQ(b.keyframes[1].position, (Vec3d{0.2, 0, 0.5}));
  EXPECT_EQ(b.keyframes[1].orientation, (Quatd{0, 0, 0, 2}));  // normalised when the tool is added
}

TEST(SceneParse, BadToolCsvNamesFileAndLine) {
  TempDir dir;
  auto error = [&](const std::string& csv) {
    dir.write("p.csv", csv);
    try {
      parse_scene(R"({"bodies": [{"mesh": {"box": {}}}], "tools": [{"shape": {"sphere": {"radius": 1}}, "path": {"csv": "p.csv"}}]})",
                  "t.json", dir.path());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("time,x,y\n0,0,0\n").find("no \"z\""), std::string::npos) << error("time,x,y\n0,0,0\n");
  EXPECT_NE(error("time,x,y,z\n0,0,0,0\n1,0,zero,0\n").find("p.csv:3: column y is \"zero\""), std::string::npos)
      << error("time,x,y,z\n0,0,0,0\n1,0,zero,0\n");
  EXPECT_NE(error("time,x,y,z\n1,0,0,0\n0,0,0,0\n").find("p.csv:3: times must increase"), std::string::npos);
  EXPECT_NE(error("time,x,y,z\n0,0,0\n").find("p.csv:2: 3 values where the header has 4"), std::string::npos);
  EXPECT_NE(error("time,x,y,z\n").find("no keyframe rows"), std::string::npos);
  EXPECT_NE(error("time,x,y,z,qw\n0,0,0,0,1\n").find("all of qw,qx,qy,qz"), std::string::npos);
  EXPECT_NE(error("time,x,y,z\n").find("tools[0].path.csv"), std::string::npos);
}

TEST(SceneParse, MessageShowsExpectationAndValue) {
  EXPECT_NE(error_of(R"({"bodies": [{"mesh": {"box": {}}, "material": {"poisson": 0.7}}]})")
                .find("t.json: bodies[0].material.poisson: must be in [0, 0.5), got 0.7"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"bodies": [{"mesh": {"box": {}}, "material": {"young": "soft"}}]})")
                .find("expected a number, got string \"soft\""),
            std::string::npos);
}

TEST(SceneParse, BadJsonGivesLineAndColumn) {
  const std::string e = error_of("{\n  \"duration\": 1,\n  \"bodies\": ]\n}");
  EXPECT_NE(e.find("t.json:3:13: invalid JSON"), std::string::npos) << e;
  const std::string end = error_of("{\"bodies\": [\n");
  EXPECT_NE(end.find("t.json:2:1: invalid JSON"), std::string::npos) << end;
  EXPECT_NE(error_of("{\n \"duration\": 1e400}").find("t.json:2:14: invalid JSON"), std::string::npos);
  // A NUL byte ended what was read: what came after it was ignored without a word.
  const std::string nul = error_of(std::string("{\"duration\": 1, \"bodies\": [{\"mesh\": {\"box\": {}}}]}\n\0garbage", 59));
  EXPECT_NE(nul.find("t.json:2:1: a NUL byte"), std::string::npos) << nul;
}

TEST(SceneParse, RelativePathsResolvedAgainstBaseDir) {
  TempDir tmp;
  const std::string json = R"({"bodies": [{"mesh": {"file": "meshes/../beam.vtu"}}]})";
  const SceneDef s = parse_scene(json, "r.json", tmp.path());
  EXPECT_EQ(s.bodies[0].mesh.path, fs::absolute(tmp.path() / "beam.vtu").lexically_normal());
  EXPECT_TRUE(s.bodies[0].mesh.path.is_absolute());
  // The same text elsewhere does not find the file.
  EXPECT_THROW(parse_scene(json, "r.json", tmp.path() / "meshes"), InputError);
}

TEST(SceneParse, LoadSceneFileUsesItsFolder) {
  TempDir tmp;
  const fs::path file = tmp.write("scene.json", R"({"bodies": [{"mesh": {"surface": "meshes/skin.obj", "cell_size": 0.02}}]})");
  const SceneDef s = load_scene_file(file);
  EXPECT_EQ(s.source, file);
  EXPECT_EQ(s.bodies[0].mesh.path, fs::absolute(tmp.path() / "meshes/skin.obj").lexically_normal());

  const fs::path bad = tmp.write("bad.json", R"({"bodies": [{"mesh": {"box": {"tets_per_cell": 4}}}]})");
  try {
    load_scene_file(bad);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bad.string() + ": bodies[0].mesh.box.tets_per_cell: "),
              std::string::npos)
        << e.what();
  }
}

TEST(SceneParse, MissingSceneFileNamesIt) {
  TempDir tmp;
  const fs::path missing = tmp.path() / "nope.json";
  try {
    load_scene_file(missing);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
  }
}

// ---- overrides ----

TEST(SceneOverrides, ModifyTheRightValues) {
  const std::string base = R"({"_note": "keep me", "bodies": [
      {"name": "a", "mesh": {"box": {"cells": [10, 1, 1]}}},
      {"name": "b", "mesh": {"box": {}}, "material": {"young": 1e5}}]})";
  const std::string out = apply_scene_overrides(
      base,
      {"bodies[0].mesh.box.cells=[20,2,2]", "precision=\"float\"", "time_step.courant=0.3",
       "bodies[1].material.young = 2e5", "gravity=[0,0,-1]", "bodies[0].material.damping.mass=0.5"},
      "o.json");
  const SceneDef s = parse_scene(out, "o.json", "");
  EXPECT_EQ(s.bodies[0].mesh.cells, (std::array<int, 3>{20, 2, 2}));
  EXPECT_EQ(s.world.precision, Precision::float32);
  EXPECT_DOUBLE_EQ(s.world.time_step.courant, 0.3);
  EXPECT_DOUBLE_EQ(s.bodies[1].material.young, 2e5);
  EXPECT_DOUBLE_EQ(s.bodies[0].material.young, 1e6);  // untouched
  EXPECT_DOUBLE_EQ(s.bodies[0].material.damping.mass, 0.5);
  EXPECT_EQ(s.world.gravity, (Vec3d{0, 0, -1}));
  EXPECT_NE(out.find("keep me"), std::string::npos);
  // An element of an existing array.
  const SceneDef t = parse_scene(apply_scene_overrides(out, {"gravity[2]=-3"}, "o.json"), "o", "");
  EXPECT_EQ(t.world.gravity, (Vec3d{0, 0, -3}));
}

TEST(SceneOverrides, BadOverridesNameThemselves) {
  const std::string base = R"({"bodies": [{"mesh": {"box": {}}}]})";
  for (const std::string o : {"bodies[0].materail.young=1", "bodies[3].name=\"x\"", "precision=float",
                              "time_step.courant", "bodies..name=1", "[0]=1", "duration.x=1",
                              "bodies[x].name=1", "probes[0].name=\"p\"", "bodies.name=1", "=1"}) {
    try {
      apply_scene_overrides(base, {o}, "o.json");
      ADD_FAILURE() << o << ": no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("o.json: override \"" + o + "\""), std::string::npos)
          << e.what();
    }
  }
  // The unknown key is named with its path.
  try {
    apply_scene_overrides(base, {"bodies[0].materail.young=1"}, "o.json");
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bodies[0].materail: unknown key"), std::string::npos) << e.what();
  }
}

// Found by fuzz_overrides (tests/fuzz): a comment key ("//...", free-form, no key list) that is not
// valid UTF-8 was put into the document, whose dump then threw nlohmann's type_error 316 out of
// apply_scene_overrides, an exception that is not an InputError (`pliant study` would have
// terminated). Every key of an override path is checked to be UTF-8, and refused naming the override.
TEST(SceneOverrides, AKeyThatIsNotUtf8IsRefusedNamingTheOverride) {
  const std::string base = R"({"bodies": [{"mesh": {"box": {}}}]})";
  for (const std::string o : {std::string("time_step.//coura\xef" "t=0.3"), std::string("//\xff=1"),
                              std::string("bodies[0].//\xc3=\"x\""), std::string("//a\xe2\x82=1")}) {
    try {
      apply_scene_overrides(base, {o}, "o.json");
      ADD_FAILURE() << o << ": no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("o.json: override \"" + o + "\""), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("not valid UTF-8"), std::string::npos) << e.what();
    }
  }
  // A UTF-8 comment key is kept.
  const std::string out = apply_scene_overrides(base, {"time_step.//note=\"d\u00e9j\u00e0 vu\"", "//\xc3\xa9t\xc3\xa9=1"}, "o.json");
  EXPECT_NE(out.find("\"//note\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"//\xc3\xa9t\xc3\xa9\""), std::string::npos) << out;
}

namespace {

// A scene path that is a FIFO (its open waited for a writer), a link to /dev/zero (read until
// memory ran out) or a directory: refused, naming the path and what it is. A scene's mesh file
// that is one of those is refused by the scene reader too.
TEST(SceneFile, OnlyRegularFilesAreRead) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pliant_test_scene_special_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto error_of = [](const fs::path& p) {
    try {
      pliant::load_scene_file(p);
    } catch (const pliant::InputError& e) {
      return std::string(e.what());
    } catch (const std::exception& e) {
      return std::string("not an InputError: ") + e.what();
    }
    return std::string("no error");
  };
  {
    const pliant::special::Fifo fifo(dir / "fifo.json");
    EXPECT_NE(error_of(fifo.path()).find(fifo.path().string() + ": is a FIFO (named pipe), not a regular file"),
              std::string::npos)
        << error_of(fifo.path());
    EXPECT_FALSE(fifo.opened());
  }
  const fs::path zero = pliant::special::link_to_dev_zero(dir / "zero.json");
  EXPECT_NE(error_of(zero).find("character device"), std::string::npos) << error_of(zero);
  EXPECT_NE(error_of(dir).find("is a directory"), std::string::npos) << error_of(dir);
  // A scene naming a mesh file that is a link to /dev/zero.
  pliant::special::link_to_dev_zero(dir / "zero.msh");
  { std::ofstream(dir / "mesh_zero.json") << R"({"bodies": [{"mesh": {"file": "zero.msh"}}]})"; }
  EXPECT_NE(error_of(dir / "mesh_zero.json").find("zero.msh"), std::string::npos) << error_of(dir / "mesh_zero.json");
  EXPECT_NE(error_of(dir / "mesh_zero.json").find("not a regular file"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace

