#!/usr/bin/env python3
"""Draco's bits per vertex on a mesh, for the format section of the bench report (issue 4).

Usage: python3 tools/bench/draco_bits.py [--decode-runs N] MESH.ply [MESH.ply ...]
(needs `pip install DracoPy`)

Each mesh (ASCII or binary little-endian PLY with vertex x, y, z and a face list) is triangulated
(quads split along corner 0-2, as Draco stores triangles only) and encoded with Draco at 12-bit
position quantization, compression level 10 (the slowest, smallest). Prints bytes and bits per
vertex; with `--decode-runs N`, also the best of N decodes of that encoding with DracoPy.decode
(wall and thread CPU time, after one warm-up decode; the chunks area of the bench compares it
with the MRQ decoder). Get the finest levels as PLY with
`OCTOWRAP_DUMP_FINEST=DIR cargo run --release -p octowrap-bench -- format`.
"""
import struct
import sys
import time

import DracoPy


def read_ply(path):
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        fmt = next(l.split()[1] for l in header if l.startswith("format"))
        elements, cur = [], None
        for l in header:
            p = l.split()
            if p[0] == "element":
                cur = [p[1], int(p[2]), []]
                elements.append(cur)
            elif p[0] == "property":
                cur[2].append(p[1:])
        types = {"float": "f", "float32": "f", "double": "d", "float64": "d", "uchar": "B", "uint8": "B",
                 "char": "b", "int8": "b", "ushort": "H", "uint16": "H", "short": "h", "int16": "h",
                 "uint": "I", "uint32": "I", "int": "i", "int32": "i"}
        verts, faces = [], []
        body = f.read()
    if fmt == "ascii":
        tokens = body.split()
        pos = 0
        for name, count, props in elements:
            for _ in range(count):
                if name == "vertex":
                    vals = [float(t) for t in tokens[pos:pos + len(props)]]
                    pos += len(props)
                    verts.append(vals[:3])
                else:
                    n = int(tokens[pos])
                    faces.append([int(t) for t in tokens[pos + 1:pos + 1 + n]])
                    pos += 1 + n
        return verts, faces
    assert fmt == "binary_little_endian", fmt
    off = 0
    for name, count, props in elements:
        for _ in range(count):
            if name == "vertex":
                row = []
                for p in props:
                    t = types[p[0]]
                    row.append(struct.unpack_from("<" + t, body, off)[0])
                    off += struct.calcsize(t)
                verts.append(row[:3])
            else:
                p = props[0]
                ct, it = types[p[1]], types[p[2]]
                n = struct.unpack_from("<" + ct, body, off)[0]
                off += struct.calcsize(ct)
                faces.append(list(struct.unpack_from("<%d%s" % (n, it), body, off)))
                off += n * struct.calcsize(it)
    return verts, faces


def decode_times(data, runs):
    """Best wall and thread CPU seconds of `runs` decodes of `data`, after a warm-up decode."""
    DracoPy.decode(data)
    wall = cpu = float("inf")
    for _ in range(runs):
        w, c = time.perf_counter(), time.thread_time()
        DracoPy.decode(data)
        wall, cpu = min(wall, time.perf_counter() - w), min(cpu, time.thread_time() - c)
    return wall, cpu


def main():
    args = sys.argv[1:]
    runs = 0
    if args[:1] == ["--decode-runs"]:
        runs, args = int(args[1]), args[2:]
    for path in args:
        verts, faces = read_ply(path)
        tris = []
        for f in faces:
            for k in range(1, len(f) - 1):
                tris.append([f[0], f[k], f[k + 1]])
        flat = [c for v in verts for c in v]
        data = DracoPy.encode(flat, faces=[i for t in tris for i in t], quantization_bits=12,
                              compression_level=10)
        line = (f"{path}: {len(verts)} vertices, {len(tris)} triangles, Draco 12-bit: {len(data)} bytes, "
                f"{len(data) * 8 / len(verts):.2f} bits/vertex")
        if runs > 0:
            wall, cpu = decode_times(data, runs)
            line += f", decode best of {runs}: {wall * 1e3:.3f} ms wall, {cpu * 1e3:.3f} ms CPU"
        print(line)


if __name__ == "__main__":
    main()
