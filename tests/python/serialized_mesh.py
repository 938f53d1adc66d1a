"""Writes Mitsuba's serialized mesh files (the format of Mitsuba's `serialized` shape, read by
src/caustica/scene/loaders/serialized_loader.cpp): each mesh a header (0x041C, version) and a zlib stream,
then the meshes' offsets and their count. Used by the tests and by bench/compare_mitsuba_xml.py."""
import struct
import zlib

import numpy as np


def mesh_bytes(positions, indices, normals=None, uvs=None, colours=None, name="mesh", version=4, double=False,
               flags_extra=0):
    flags = (0x2000 if double else 0x1000) | flags_extra
    arrays = [positions]
    for bit, a in ((0x0001, normals), (0x0002, uvs), (0x0008, colours)):
        if a is not None:
            flags |= bit
            arrays.append(a)
    body = struct.pack("<I", flags)
    if version == 4:
        body += name.encode() + b"\0"
    body += struct.pack("<QQ", len(positions), len(indices))
    ft = np.float64 if double else np.float32
    for a in arrays:
        body += np.ascontiguousarray(a, ft).tobytes()
    body += np.ascontiguousarray(indices, np.uint32).tobytes()
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


def write_serialized(path, meshes, version=4, double=False):
    """meshes: dicts with positions (n, 3), indices (m, 3) and optional normals, uvs (Mitsuba's: v down),
    colours, name."""
    out, offsets = b"", []
    for m in meshes:
        offsets.append(len(out))
        out += mesh_bytes(version=version, double=double, **m)
    fmt = "<Q" if version == 4 else "<I"
    out += b"".join(struct.pack(fmt, o) for o in offsets) + struct.pack("<I", len(meshes))
    with open(path, "wb") as f:
        f.write(out)
