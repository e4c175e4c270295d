#!/usr/bin/env python3
"""Write files that other tools make and hdrvis must read, and report what the reference reads.

    python3 tests/python/write_reader_cases.py OUT_DIR CASE

Each case writes its files into OUT_DIR and prints one `KEY VALUE ...` line per reference value,
read back with the writing tool itself:

  hdf5_lz4   lz4.h5 (h5py + hdf5plugin): LZ4-filtered (id 32004) datasets whose LZ4 blocks are
             smaller than the chunk: /smooth (f32 in runs, 256-byte blocks,
             compressed), /noise (f64,
             100-byte blocks, a short last block, stored raw) and /counts (int16, one block per
             chunk). Keys: the dataset names, values in C order.

Exit status 77 (skipped) when a module a case needs is not installed.
"""

import os
import sys


def need(*modules):
    """The modules, imported; exit 77 when one is missing."""
    try:
        return [__import__(m) for m in modules]
    except ImportError as exc:  # pragma: no cover - depends on the machine
        print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
        sys.exit(77)


def report(key, values):
    print(key, " ".join(repr(float(v)) for v in values))


def hdf5_lz4(out):
    np, h5py, hdf5plugin = need("numpy", "h5py", "hdf5plugin")
    z, y, x = np.meshgrid(np.arange(4), np.arange(8), np.arange(16), indexing="ij")
    smooth = (0.5 * (x // 8) - 3.0 * (y // 4) + 100.0 * z).astype("f4")
    noise = np.random.default_rng(7).normal(size=(4, 8, 16))
    counts = (x * y - z * 7).astype("i2")
    path = os.path.join(out, "lz4.h5")
    with h5py.File(path, "w") as f:
        f.create_dataset("smooth", data=smooth, chunks=(2, 8, 16), **hdf5plugin.LZ4(nbytes=256))
        f.create_dataset("noise", data=noise, chunks=(2, 8, 16), **hdf5plugin.LZ4(nbytes=100))
        f.create_dataset("counts", data=counts, chunks=(2, 4, 16), **hdf5plugin.LZ4())
    with h5py.File(path, "r") as f:
        for name in ("smooth", "noise", "counts"):
            assert "32004" in f[name]._filters, name
            report(name, f[name][()].ravel())


CASES = {"hdf5_lz4": hdf5_lz4}


def main():
    out, case = sys.argv[1], sys.argv[2]
    CASES[case](out)


if __name__ == "__main__":
    main()
