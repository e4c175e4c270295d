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
  partial    odd.h5 (h5py): /good (f32, units "m", an attribute of invalid UTF-8), /vds (a
             virtual dataset of src.h5's /a), /t (a committed datatype) and /typed (f32 in it), and
             /g/inner; odd.nc: a NetCDF-4 file from netCDF4 with variables good and other, to
             which h5py adds a root attribute of invalid UTF-8, a committed datatype /t and a
             dataset /typed of it; vds.nc: a NetCDF-4 file with a variable other and a virtual
             dataset vds added by h5py (netCDF4 reads both). Keys: good, typed, inner, other
             (values in C order).
  strings    strings.nc (NetCDF-4) and strings3.nc (classic) from netCDF4: station_name (NC_STRING,
             NetCDF-4 only), label (a char array) and temp (f4, 2x3x4). Key: temp.
  exr        OpenEXR images (OpenEXR module), 6x4 pixels, values from a fixed random generator:
             y.exr (Y only, half), r.exr (R only), rg.exr (R and G, and an extra channel Z),
             yc.exr (Y, RY, BY at full resolution), yc_p3.exr (the same with P3-D65
             chromaticities), yc_sub.exr (RY and BY subsampled 2 x 2, as OpenEXR's
             luminance-chroma files are) and zstd.exr (R, G, B, ZSTD-compressed). Keys: FILE_CHANNEL for
             each stored channel as OpenEXR reads it, and yc_R/G/B, yc_p3_R/G/B: the RGB of the
             luminance-chroma files (R = (RY+1) Y, B = (BY+1) Y, G from Y with the luminance
             weights of the primaries (Rec. 709's, OpenEXR's default, without the
             attribute), computed here by inverting the RGB-to-XYZ matrix).

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


def partial(out):
    np, h5py, netCDF4 = need("numpy", "h5py", "netCDF4")
    a = np.linspace(-1.5, 4.0, 60, dtype="f4").reshape(3, 4, 5)
    with h5py.File(os.path.join(out, "src.h5"), "w") as f:
        f["a"] = a
    with h5py.File(os.path.join(out, "odd.h5"), "w") as f:
        f["good"] = a
        f["good"].attrs["units"] = "m"
        f["good"].attrs["note"] = np.bytes_(b"caf\xe9 \xff")
        layout = h5py.VirtualLayout(shape=a.shape, dtype="f4")
        layout[:] = h5py.VirtualSource("src.h5", "a", shape=a.shape)
        f.create_virtual_dataset("vds", layout)
        f["t"] = np.dtype("f4")
        f.create_dataset("typed", data=a * 2, dtype=f["t"])
        f.create_group("g")["inner"] = a * 3
    with h5py.File(os.path.join(out, "odd.h5"), "r") as f:
        assert np.array_equal(f["vds"][()], a)
        for name in ("good", "typed", "g/inner"):
            report(name.split("/")[-1], f[name][()].ravel())
    nc = os.path.join(out, "odd.nc")
    with netCDF4.Dataset(nc, "w") as d:
        for name, n in zip("zyx", a.shape):
            d.createDimension(name, n)
        d.createVariable("good", "f4", ("z", "y", "x"))[:] = a
        d.createVariable("other", "f4", ("z", "y", "x"))[:] = a * 5
    with h5py.File(nc, "a") as f:
        f.attrs["title"] = np.bytes_(b"\xff\xfe")
        f["t"] = np.dtype("f4")
        f.create_dataset("typed", data=a * 2, dtype=f["t"])
    with h5py.File(nc, "r") as f:
        report("other", f["other"][()].ravel())
    vds = os.path.join(out, "vds.nc")
    with netCDF4.Dataset(vds, "w") as d:
        for name, n in zip("zyx", a.shape):
            d.createDimension(name, n)
        d.createVariable("other", "f4", ("z", "y", "x"))[:] = a * 5
    with h5py.File(vds, "a") as f:
        layout = h5py.VirtualLayout(shape=a.shape, dtype="f4")
        layout[:] = h5py.VirtualSource("src.h5", "a", shape=a.shape)
        f.create_virtual_dataset("vds", layout)
    with netCDF4.Dataset(vds) as d:
        assert np.array_equal(d["vds"][:], a) and np.array_equal(d["other"][:], a * 5)


def strings(out):
    np, netCDF4 = need("numpy", "netCDF4")
    temp = np.linspace(250.0, 300.0, 24, dtype="f4").reshape(2, 3, 4)
    for name, fmt in (("strings.nc", "NETCDF4"), ("strings3.nc", "NETCDF3_CLASSIC")):
        with netCDF4.Dataset(os.path.join(out, name), "w", format=fmt) as d:
            for dim, n in (("station", 3), ("strlen", 8), ("z", 2), ("y", 3), ("x", 4)):
                d.createDimension(dim, n)
            if fmt == "NETCDF4":
                names = d.createVariable("station_name", str, ("station",))
                names[:] = np.array(["Aberdeen", "Bergen", "Cork"], dtype=object)
            label = d.createVariable("label", "S1", ("station", "strlen"))
            label[:] = netCDF4.stringtochar(np.array(["one", "two", "three"], dtype="S8"))
            d.createVariable("temp", "f4", ("z", "y", "x"))[:] = temp
        with netCDF4.Dataset(os.path.join(out, name)) as d:
            report("temp", d["temp"][:].ravel())


def luminance_weights(np, primaries):
    """Y of R, G, B = 1 each: the middle row of the RGB-to-XYZ matrix, summing to 1."""
    (rx, ry), (gx, gy), (bx, by), (wx, wy) = primaries
    m = np.array([[rx / ry, gx / gy, bx / by], [1.0, 1.0, 1.0],
                  [(1 - rx - ry) / ry, (1 - gx - gy) / gy, (1 - bx - by) / by]])
    scale = np.linalg.solve(m, [wx / wy, 1.0, (1 - wx - wy) / wy])
    return scale / scale.sum()


def exr(out):
    np, OpenEXR = need("numpy", "OpenEXR")
    rng = np.random.default_rng(11)
    plane = lambda lo, hi: rng.uniform(lo, hi, size=(4, 6)).astype("f4")
    zip_ = {"compression": OpenEXR.ZIP_COMPRESSION}
    y, ry, by = plane(0.5, 40.0), plane(-0.4, 0.6), plane(-0.5, 0.3)
    p3 = ((0.68, 0.32), (0.265, 0.69), (0.15, 0.06), (0.3127, 0.329))
    files = {
        "y.exr": (zip_, {"Y": y.astype("f2")}),
        "r.exr": (zip_, {"R": plane(0.0, 5.0)}),
        "rg.exr": (zip_, {"R": plane(0.0, 5.0), "G": plane(1.0, 2.0), "Z": plane(10.0, 20.0)}),
        "yc.exr": (zip_, {"Y": y, "RY": ry, "BY": by}),
        "yc_p3.exr": (dict(zip_, chromaticities=sum(p3, ())), {"Y": y, "RY": ry, "BY": by}),
        "zstd.exr": ({"compression": OpenEXR.ZSTD_COMPRESSION},
                     {"R": plane(0, 1), "G": plane(0, 1), "B": plane(0, 1)}),
    }
    for name, (header, channels) in files.items():
        OpenEXR.File(header, channels).write(os.path.join(out, name))
    # OpenEXR's own luminance-chroma layout: RY and BY at one sample per 2 x 2 pixels.
    sub = os.path.join(out, "yc_sub.exr")
    OpenEXR.File(zip_, {"Y": OpenEXR.Channel(y), "RY": OpenEXR.Channel(ry, 2, 2),
                        "BY": OpenEXR.Channel(by, 2, 2)}).write(sub)
    with OpenEXR.File(sub) as f:
        sampling = {k: (c.xSampling, c.ySampling) for k, c in f.channels().items()}
        assert sampling == {"Y": (1, 1), "RY": (2, 2), "BY": (2, 2)}, sampling
    for name in files:
        with OpenEXR.File(os.path.join(out, name)) as f:
            for channel, c in f.channels().items():
                report(f"{name[:-4]}_{channel}", c.pixels.astype("f8").ravel())
    rec709 = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06), (0.3127, 0.329))
    for name, primaries in (("yc", rec709), ("yc_p3", p3)):
        weights = luminance_weights(np, primaries)
        r, b = (ry + 1.0) * y, (by + 1.0) * y
        g = (y - weights[0] * r - weights[2] * b) / weights[1]
        for channel, v in zip("RGB", (r, g, b)):
            report(f"{name}_{channel}", v.astype("f8").ravel())


def float64(out):
    np, h5py = need("numpy", "h5py")
    z = 1.0 + np.arange(12).reshape(3, 4) * 1e-12 + np.array([0.0, 1e8, -1e-300, 0.0])
    with h5py.File(os.path.join(out, "float64.h5"), "w") as f:
        f.create_dataset("z", data=z)
    report("z", z.ravel())


CASES = {"float64": float64, "hdf5_lz4": hdf5_lz4, "partial": partial, "strings": strings, "exr": exr}


def main():
    out, case = sys.argv[1], sys.argv[2]
    CASES[case](out)


if __name__ == "__main__":
    main()
