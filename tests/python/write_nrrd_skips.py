#!/usr/bin/env python3
"""Write NRRD files whose data start after a `line skip` or `byte skip`, each checked with pynrrd.

    python3 tests/python/write_nrrd_skips.py OUT_DIR

The volume has nx=4, ny=3, nz=2 float32 values from -28.3 to 1234.5. OUT_DIR gets:

  expect.npy           the values, shape (nz, ny, nx), C order (x fastest)
  lineskip.nhdr        detached; lineskip.raw holds three text lines, then the raw values
  lineskip_gzip.nrrd   attached; two text lines after the header, then a gzip stream
  byteskip.nhdr        detached; byteskip.raw holds 13 binary bytes (newlines among them) first
  byteskip_end.nhdr    detached, `byte skip: -1`; byteskip_end.raw has 17 bytes before the values

Every file is read back with pynrrd (nrrd.read) and must give the values. pynrrd 1.1.3 applies a
gzip `byte skip` both before and after decompression, so no compressed file here has one.
Exit status 77 (skipped) when numpy or pynrrd is not installed.
"""

import gzip
import os
import sys

try:
    import numpy as np
    import nrrd
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install numpy pynrrd)", file=sys.stderr)
    sys.exit(77)

HEADER = "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3 2\nendian: little\n"


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def main():
    out = sys.argv[1]
    values = np.linspace(-28.3, 1234.5, 24, dtype=np.float32).reshape(2, 3, 4)
    np.save(os.path.join(out, "expect.npy"), values)
    raw = values.astype("<f4").tobytes()
    files = {
        "lineskip.nhdr": ("encoding: raw\nline skip: 3\ndata file: lineskip.raw\n",
                          ("lineskip.raw", b"P7\n# made by a header-writing tool\n4 3 2\n" + raw)),
        "byteskip.nhdr": ("encoding: raw\nbyte skip: 13\ndata file: byteskip.raw\n",
                          ("byteskip.raw", b"\n\x00\x01\n\xff" + b"\n" * 8 + raw)),
        "byteskip_end.nhdr": ("encoding: raw\nbyte skip: -1\ndata file: byteskip_end.raw\n",
                              ("byteskip_end.raw", bytes(range(17)) + raw)),
    }
    for name, (fields, (data_name, data)) in files.items():
        write(os.path.join(out, data_name), data)
        write(os.path.join(out, name), (HEADER + fields).encode())
    attached = (HEADER + "encoding: gzip\nline skip: 2\n\n").encode()
    attached += b"first line\nsecond line\n" + gzip.compress(raw)
    write(os.path.join(out, "lineskip_gzip.nrrd"), attached)
    for name in list(files) + ["lineskip_gzip.nrrd"]:
        data, _ = nrrd.read(os.path.join(out, name), index_order="C")
        assert np.array_equal(data, values), f"pynrrd reads {name} as {data}"


if __name__ == "__main__":
    main()
