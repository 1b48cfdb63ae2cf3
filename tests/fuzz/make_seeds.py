#!/usr/bin/env python3
"""Seed corpora for the libFuzzer harnesses of tests/fuzz (run by scripts/fuzz.sh).

usage: make_seeds.py SOURCE_DIR OUT_DIR

Writes OUT_DIR/<harness>/<name> from the repository's own files: tests/data/mesh, the small
meshes of data/meshes (at most MAX_BYTES each, so that an input stays quick to run) and scenes/.
What the files on disk do not cover is generated here: binary VTU (base64, zlib, UInt32/UInt64
headers, both byte orders, a point array), TetGen pairs joined by a NUL byte, and `--sweep` lines
joined to a scene by a NUL byte (the input layouts of fuzz_tetgen.cpp and fuzz_overrides.cpp).
"""
import base64
import pathlib
import shutil
import struct
import sys
import zlib

MAX_BYTES = 64 * 1024

src = pathlib.Path(sys.argv[1])
out = pathlib.Path(sys.argv[2])


def small(paths):
    return [p for p in sorted(paths) if p.is_file() and p.stat().st_size <= MAX_BYTES]


def put(harness, name, data):
    d = out / harness
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


mesh_dirs = [src / "tests/data/mesh", src / "data/meshes"]
for ext, harness in [(".msh", "gmsh"), (".vtk", "vtk"), (".vtu", "vtu"), (".obj", "obj")]:
    for d in mesh_dirs:
        for p in small(d.glob("*" + ext)):
            put(harness, f"{d.parent.name}_{p.name}", p.read_bytes())
# An XML grid misnamed .vtk is read as .vtu: the .vtk harness gets the .vtu seeds too.
for p in small((src / "tests/data/mesh").glob("*.vtu")):
    put("vtk", "xml_" + p.name, p.read_bytes())

# OBJ: the shipped surfaces are large; a small one in every face form the reader takes.
put("obj", "gen_forms.obj", "# cube corner\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\n"
    "f 1 3 2\nf 1/1 2/1 4/1\nf 1//1 4//1 3//1\nf -3/1/1 -2/1/1 -1/1/1\nf 1 2 3 4\n")
for p in sorted((src / "data/meshes").glob("*.obj")):
    # Its first 200 vertices and up to 200 faces on them.
    vs, fs = [], []
    for line in p.read_bytes().splitlines(keepends=True):
        if line.startswith(b"v ") and len(vs) < 200:
            vs.append(line)
        elif line.startswith(b"f ") and len(fs) < 200:
            idx = [int(t.split(b"/")[0]) for t in line.split()[1:]]
            if all(0 < i <= 200 for i in idx):
                fs.append(line)
    put("obj", "head_" + p.name, b"".join(vs + fs))

# TetGen: "<.node>\0<.ele>".
for node in small((src / "tests/data/mesh").glob("*.node")):
    ele = node.with_suffix(".ele")
    put("tetgen", node.stem, node.read_bytes() + b"\0" + (ele.read_bytes() if ele.exists() else b""))


# Binary VTU: the cube of tests/data/mesh/cube.vtu (9 points, a triangle and 5 tets).
def vtu(zlib_on, header64, big, points64, conn64, separate=True):
    e = ">" if big else "<"
    pts = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 9, 9, 9]
    cells = [[0, 1, 2], [0, 1, 3, 4], [1, 2, 3, 6], [1, 4, 5, 6], [3, 4, 6, 7], [1, 3, 4, 6]]
    p = struct.pack(e + ("d" if points64 else "f") * len(pts), *pts)
    it = "q" if conn64 else "i"
    flat = [v for c in cells for v in c]
    conn = struct.pack(e + it * len(flat), *flat)
    offs, o = [], 0
    for c in cells:
        o += len(c)
        offs.append(o)
    offs = struct.pack(e + it * len(offs), *offs)
    types = bytes(5 if len(c) == 3 else 10 for c in cells)
    disp = struct.pack(e + "d" * 27, *[0.01 * i for i in range(27)])
    hw = e + ("Q" if header64 else "I")

    def enc(raw):
        if zlib_on:
            z = zlib.compress(raw, 6)
            header = [1, len(raw), len(raw), len(z)]
            body = z
        else:
            header = [len(raw)]
            body = raw
        h = b"".join(struct.pack(hw, w) for w in header)
        if separate:
            return (base64.b64encode(h) + base64.b64encode(body)).decode()
        return base64.b64encode(h + body).decode()

    ityp = "Int64" if conn64 else "Int32"
    comp = ' compressor="vtkZLibDataCompressor"' if zlib_on else ""
    return (
        '<?xml version="1.0"?>\n'
        f'<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{"BigEndian" if big else "LittleEndian"}"'
        f' header_type="{"UInt64" if header64 else "UInt32"}"{comp}>\n<UnstructuredGrid>\n'
        '<Piece NumberOfPoints="9" NumberOfCells="6">\n<PointData>\n'
        f'<DataArray type="Float64" Name="displacement" NumberOfComponents="3" format="binary">{enc(disp)}</DataArray>\n'
        '</PointData>\n<CellData></CellData>\n<Points>\n'
        f'<DataArray type="{"Float64" if points64 else "Float32"}" NumberOfComponents="3" format="binary">{enc(p)}</DataArray>\n'
        '</Points>\n<Cells>\n'
        f'<DataArray type="{ityp}" Name="connectivity" format="binary">{enc(conn)}</DataArray>\n'
        f'<DataArray type="{ityp}" Name="offsets" format="binary">{enc(offs)}</DataArray>\n'
        f'<DataArray type="UInt8" Name="types" format="binary">{enc(types)}</DataArray>\n'
        "</Cells>\n</Piece>\n</UnstructuredGrid>\n"
        '<FieldData><DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="ascii">0.5</DataArray></FieldData>\n'
        "</VTKFile>\n"
    )


for z in (False, True):
    for h64 in (False, True):
        for big in (False, True):
            name = f"gen_{'zlib' if z else 'base64'}_{'u64' if h64 else 'u32'}_{'be' if big else 'le'}.vtu"
            put("vtu", name, vtu(z, h64, big, points64=h64, conn64=big))
put("vtu", "gen_base64_onestream.vtu", vtu(False, False, False, False, False, separate=False))

# Scenes: the shipped ones and the validation scenes.
scenes = small((src / "scenes").glob("*.json")) + small((src / "scenes").glob("*/*.json"))
for p in scenes:
    put("scene", p.name, p.read_bytes())

# Sweeps + scene: "<sweep lines>\0<scene>".
sweeps = [
    "bodies[0].mesh.box.cells=[8,2,2]|[16,4,4]",
    'precision="float"|"double"\ntime_step.courant=0.3|0.5',
    'bodies[0].model="linear"|"stvk"|"corotational"',
    "bodies[0].material.poisson=0.3\nduration=0.01",
    'gravity[2]=-9.81|0\nbodies[0].material={"young": 1e4, "poisson": 0.3}',
]
for i, p in enumerate(scenes):
    put("overrides", f"{i:02d}_{p.stem}", sweeps[i % len(sweeps)].encode() + b"\0" + p.read_bytes())

# Inputs that once found a defect (tests/fuzz/regressions/<harness>-<what>): replayed first.
for p in sorted((src / "tests/fuzz/regressions").glob("*-*")):
    put(p.name.split("-")[0], "regression_" + p.name, p.read_bytes())
