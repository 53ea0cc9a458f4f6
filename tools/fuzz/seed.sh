#!/usr/bin/env bash
# Builds tools/fuzz/corpus/<target>/ for every reader target, the MRQ decoder and the chunked reader
# from fixtures/ (and synthetic version 5 files for the chunked reader) and from the small, non-GPL
# files of ../shared/data (each data folder's PROVENANCE.md states its licence; the lidR LAZ files
# and the PyMeshLab range map are GPL and left out). Nothing here is committed: the corpora live in
# the git-ignored corpus/ folder. Files over 128 KiB (the targets' -max_len) are skipped. Safe to
# re-run: it only adds files.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
data=${OCTOWRAP_DATA:-$root/../shared/data}
[ -d "$data" ] || data=/work/shared/data
corpus=$here/corpus
max=$((128 * 1024))

add() { # add TARGET FILE...
    local t=$1; shift
    mkdir -p "$corpus/$t"
    for f in "$@"; do
        [ -f "$f" ] || continue
        [ "$(stat -c %s "$f")" -le "$max" ] || continue
        cp "$f" "$corpus/$t/$(basename "$f")"
    done
}

add read_obj "$root"/fixtures/meshes/*/*.obj "$data"/mesh-defects/trimesh/*.obj
add read_off "$root"/fixtures/meshes/*/*.off "$data"/cgal-data/meshes/degtri_sliding.off \
    "$data"/cgal-data/meshes/mesh_with_border.off
add read_stl "$data"/mesh-defects/trimesh/*.stl "$data"/mesh-defects/trimesh/*.STL
add read_ply "$data"/stanford-bunny/reconstruction/bun_zipper_res4.ply
add read_pcd "$data"/pcl-pcd/bunny.pcd "$data"/pcl-pcd/bun0.pcd "$data"/pcl-pcd/milk.pcd
add read_las "$data"/cgal-data/points_3/oni.las
add read_e57 "$data"/e57/tiny_spherical.e57 "$data"/e57/tinyCartesianFloatRgb.e57
add read_conf "$data"/stanford-bunny/data/bun.conf
# The MRQ decoder: the conformance files, valid, invalid and the regression ones.
add decode "$root"/fixtures/format/*/*.mrq
# The chunked reader and its cut: the conformance files as they are (checksums kept) behind the
# selection of chunk 0, then (examples/seed_chunks.rs, a few minutes to build the first time) small
# synthetic version 5 files with chunk shifts 1 and 2 and the conformance files, resealed by the
# target, behind selections that are cuts, mixed-level cuts and not cuts.
mkdir -p "$corpus/chunks"
for f in "$root"/fixtures/format/*/*.mrq; do
    { printf '\001\000\000\000'; cat "$f"; } > "$corpus/chunks/$(basename "$f" .mrq)-as_is"
done
(cd "$here" && cargo run --release --quiet --example seed_chunks -- "$corpus/chunks" "$root"/fixtures/format/*/*.mrq >/dev/null) \
    || echo "chunks: examples/seed_chunks.rs did not run: seeded with the conformance files only" >&2
# A tiny OpenEXR image from CPython's test data (PSF licence), when a CPython source tree has it.
add read_exr $(find / -name python.exr -size -64k -path "*imghdrdata*" 2>/dev/null | head -1)

mkdir -p "$corpus/read_xyz" "$corpus/read_conf" "$corpus/read_gz" "$corpus/read_exr"
head -n 200 "$root/fixtures/points/kitten.xyz" > "$corpus/read_xyz/kitten-200.xyz"
[ -f "$data/cgal-data/points_3/oni.pwn" ] && head -n 100 "$data/cgal-data/points_3/oni.pwn" > "$corpus/read_xyz/oni-100.pwn"
printf '3\n1 2 3 -120 10 20 30\n4 5 6 7 255 0 1\n1,2,3,4,5,6,7\n' > "$corpus/read_xyz/pts.pts"
printf 'camera 0 0 0 0 0 0 1\nbmesh a.ply 1 2 3 0 0 0.7071 0.7071\nbmesh b.xyz 0 0 0 0 0 0 1\n' > "$corpus/read_conf/two.conf"
printf 'v/1\001\002\000\000\000' > "$corpus/read_exr/magic.exr"

# Binary and ascii variants written by octowrap itself, when the CLI is built.
cli=$root/target/release/octowrap
if [ -x "$cli" ]; then
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    for m in "$root"/fixtures/meshes/valid/*.obj; do
        b=$(basename "$m" .obj)
        "$cli" convert "$m" "$tmp/$b.ply" >/dev/null 2>&1 || true
        "$cli" convert --ascii "$m" "$tmp/$b-ascii.ply" >/dev/null 2>&1 || true
        "$cli" convert "$m" "$tmp/$b.stl" >/dev/null 2>&1 || true
        "$cli" convert --ascii "$m" "$tmp/$b-ascii.stl" >/dev/null 2>&1 || true
        "$cli" convert "$m" "$tmp/$b.off" >/dev/null 2>&1 || true
    done
    add read_ply "$tmp"/*.ply
    add read_stl "$tmp"/*.stl
    add read_off "$tmp"/*.off
fi

# The gz target: a format byte (high bit clear: the rest is gzipped by the target), then content.
k=0
for t in read_ply read_obj read_off read_stl read_xyz read_pcd read_las read_e57 read_exr; do
    # The first seed by name (a glob, not `ls | head`: a grown corpus would end ls with SIGPIPE,
    # which pipefail turns into a failure).
    seeds=("$corpus/$t"/*)
    f=${seeds[0]}
    if [ -f "$f" ]; then
        { printf "\\$(printf '%03o' $k)"; cat "$f"; } > "$corpus/read_gz/$t-plain"
        { printf "\\$(printf '%03o' $((k + 128)))"; gzip -c -n "$f"; } > "$corpus/read_gz/$t-gzip"
    fi
    k=$((k + 1))
done
for d in "$corpus"/read_* "$corpus"/decode "$corpus"/chunks; do
    echo "$(basename "$d"): $(find "$d" -maxdepth 1 -type f | wc -l) seeds"
done
