"""The CUDA backend as built into the module (docs/gpu.md, Building): every device-code image is stored
compressed. With the backend split into five files, fatbinary's default left most files' SASS uncompressed and
the module grew from 27 to 62 MB, past what the GPU bundle can carry (dd41323 adds -Xfatbin=-compress-all).
Skipped in a build without the CUDA backend (`make build CUDA=0`)."""
import shutil
import struct
import subprocess

import pytest

from caustica import _native

FATBIN_MAGIC = 0xBA55ED50
COMPRESSED = 0x8000  # the entry flag set on every compressed image (PTX and SASS alike, as read from nvcc 13.0's output)


def _entries(blob):
    """(kind, arch, flags) of every image in a .nv_fatbin section: kind 1 PTX, 2 SASS (ELF)."""
    out, off = [], 0
    while off + 16 <= len(blob):
        magic, _, header, size = struct.unpack_from("<IHHQ", blob, off)
        if magic != FATBIN_MAGIC:
            off += 8  # fatbins are 8-byte aligned; padding between them
            continue
        e, end = off + header, off + header + size
        while e < end:
            kind, _, entry_header, entry_size = struct.unpack_from("<HHIQ", blob, e)
            arch = struct.unpack_from("<I", blob, e + 28)[0]
            flags = struct.unpack_from("<Q", blob, e + 40)[0]
            out.append((kind, arch, flags))
            e += entry_header + entry_size
        off = end
    return out


@pytest.mark.skipif(not _native.cuda_built(), reason="this build has no CUDA backend (make build CUDA=0)")
@pytest.mark.skipif(shutil.which("objcopy") is None, reason="objcopy (binutils) is not installed")
def test_every_device_image_is_compressed(tmp_path):
    section = tmp_path / "fatbin"
    subprocess.run(["objcopy", "-O", "binary", "--only-section=.nv_fatbin", _native.__file__, str(section)],
                   check=True)
    entries = _entries(section.read_bytes())
    kinds = {(k, a) for k, a, _ in entries}
    assert {(1, 80), (2, 80), (1, 90), (2, 90)} <= kinds, kinds  # PTX and SASS for sm_80 and sm_90
    loose = [(k, a) for k, a, f in entries if not f & COMPRESSED]
    assert not loose, f"{len(loose)} of {len(entries)} images stored uncompressed: {loose[:8]}"
