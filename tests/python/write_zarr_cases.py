#!/usr/bin/env python3
"""Write Zarr stores as xarray's to_zarr writes them (its default codecs) and print what
xarray.open_zarr reads from them: the reference of hdrvis's Zarr tests.

    python3 tests/python/write_zarr_cases.py OUT_DIR

Stores, each holding sst(time, lat, lon) in float32 with missing values (NaN, masked through
_FillValue), a time axis of datetime64 values (CF units written by xarray), chunked 2 x 5 x 7 so
that the edges hold partial chunks, lat/lon coordinates, and a packed int16 variable `t2m` with
scale_factor, add_offset and _FillValue, as archives pack temperatures:
  v2.zarr          zarr_format=2: Blosc (LZ4, byte shuffle), numcodecs' default
  v3.zarr          zarr_format=3: Zstandard, zarr-python's default
  v2_zlib.zarr     zarr_format=2 with a zlib compressor
Printed, one `KEY VALUE ...` line each, C order, `nan` for missing values:
  <store>.sst.t3       sst at time index 3
  <store>.t2m.t1       t2m at time index 1, decoded
  <store>.times        the dates, ISO 8601
Exit status 77 (skipped) when a module is missing.
"""

import os
import sys

try:
    import numpy as np
    import pandas as pd
    import xarray as xr
    import zarr
    import numcodecs
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)


def emit(key, values):
    flat = np.asarray(values, dtype=float).ravel()
    print(key, " ".join("nan" if np.isnan(v) else repr(float(v)) for v in flat))


def dataset():
    nt, ny, nx = 5, 12, 16
    time = pd.date_range("1979-01-01", periods=nt, freq="6h")
    lat = np.linspace(-55.0, 55.0, ny)
    lon = np.linspace(0.0, 337.5, nx)
    t, y, x = np.meshgrid(np.arange(nt), lat, lon, indexing="ij")
    sst = (15.0 + 12.0 * np.cos(np.radians(y)) + 0.5 * np.sin(np.radians(x) + t)).astype("f4")
    sst[:, :2, 3:6] = np.nan  # land
    t2m = 250.0 + 40.0 * np.cos(np.radians(y)) + np.sin(np.radians(x) * 2 + t)
    t2m[1, 5, 5] = np.nan
    ds = xr.Dataset(
        {
            "sst": (("time", "lat", "lon"), sst, {"units": "degC", "long_name": "sea surface temperature"}),
            "t2m": (("time", "lat", "lon"), t2m, {"units": "K"}),
        },
        coords={"time": time, "lat": ("lat", lat, {"units": "degrees_north"}),
                "lon": ("lon", lon, {"units": "degrees_east"})},
    )
    return ds


def write(path, zarr_format, compressor=None):
    ds = dataset()
    encoding = {
        "sst": {"chunks": (2, 5, 7)},
        "t2m": {"chunks": (2, 5, 7), "dtype": "int16", "scale_factor": 0.01, "add_offset": 273.15,
                "_FillValue": -32767},
    }
    if compressor is not None:
        for v in encoding.values():
            v["compressors"] = [compressor]
    ds.to_zarr(path, mode="w", zarr_format=zarr_format, encoding=encoding, consolidated=False)


def main(out):
    import warnings
    warnings.simplefilter("ignore")
    cases = (("v2", 2, None), ("v3", 3, None), ("v2_zlib", 2, numcodecs.Zlib(level=4)))
    for name, fmt, compressor in cases:
        path = os.path.join(out, f"{name}.zarr")
        write(path, fmt, compressor)
        ds = xr.open_zarr(path, consolidated=False)
        emit(f"{name}.sst.t3", ds.sst.isel(time=3).values)
        emit(f"{name}.t2m.t1", ds.t2m.isel(time=1).values)
        print(f"{name}.times", " ".join(str(t)[:19] for t in ds.time.values))
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
