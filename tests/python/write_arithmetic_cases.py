#!/usr/bin/env python3
"""Fields for the arithmetic tests (tests/integration/arithmetic.rs), written with netCDF4-python,
and numpy's results on the same arrays.

    python3 tests/python/write_arithmetic_cases.py OUT_DIR

writes OUT_DIR/sst.nc: sst(time=6, lat=7, lon=9) in K (float64, a few missing values, one node
missing at every step) and OUT_DIR/temp.nc: t(time=3, z=4, y=5, x=6) in K (float32), and prints
one JSON object: numpy's results, each a flat list in C order (null where missing):
  "jul_minus_jan"  sst[3] - sst[0]
  "celsius"        sst[0] - 273.15
  "twice"          2 * sst[1]
  "ratio"          sst[1] / sst[2]
  "product"        sst[0] * sst[1]
  "mean", "min", "max", "std"  np.nanmean / nanmin / nanmax / nanstd (ddof 0) over time
  "mean_1_4"       np.nanmean(sst[1:5], axis=0)
  "anomaly"        sst[3] - np.nanmean(sst, axis=0)
  "vol_diff"       float32(float64(t[1]) - float64(t[0]))
  "vol_mean"       float32(np.nanmean(float64(t), axis=0))
Exit 77 when numpy or netCDF4 is missing.
"""
import json
import os
import sys
import warnings

try:
    import netCDF4
    import numpy as np
except ImportError as e:
    print(e, file=sys.stderr)
    sys.exit(77)


def flat(a):
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, dtype=np.float64).ravel()]


def main(out):
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(7)
    sst = 271.0 + 30.0 * rng.random((6, 7, 9))
    sst[1, 2, 3] = np.nan
    sst[4, 0, 0] = np.nan
    sst[:, 6, 8] = np.nan
    with netCDF4.Dataset(os.path.join(out, "sst.nc"), "w") as ds:
        ds.createDimension("time", 6)
        ds.createDimension("lat", 7)
        ds.createDimension("lon", 9)
        t = ds.createVariable("time", "f8", ("time",))
        t.units = "days since 2000-01-01"
        t[:] = np.arange(6) * 30.0
        la = ds.createVariable("lat", "f8", ("lat",))
        la.units = "degrees_north"
        la[:] = np.linspace(-30.0, 30.0, 7)
        lo = ds.createVariable("lon", "f8", ("lon",))
        lo.units = "degrees_east"
        lo[:] = np.linspace(0.0, 80.0, 9)
        v = ds.createVariable("sst", "f8", ("time", "lat", "lon"), fill_value=-9999.0)
        v.units = "K"
        v[:] = np.ma.masked_invalid(sst)
    temp = (250.0 + 50.0 * rng.random((3, 4, 5, 6))).astype(np.float32)
    temp[2, 1, 1, 1] = np.nan
    with netCDF4.Dataset(os.path.join(out, "temp.nc"), "w") as ds:
        for name, n in [("time", 3), ("z", 4), ("y", 5), ("x", 6)]:
            ds.createDimension(name, n)
        v = ds.createVariable("t", "f4", ("time", "z", "y", "x"))
        v.units = "K"
        v[:] = temp
    t64 = temp.astype(np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        result = {
            "jul_minus_jan": flat(sst[3] - sst[0]),
            "celsius": flat(sst[0] - 273.15),
            "twice": flat(2 * sst[1]),
            "ratio": flat(sst[1] / sst[2]),
            "product": flat(sst[0] * sst[1]),
            "mean": flat(np.nanmean(sst, axis=0)),
            "min": flat(np.nanmin(sst, axis=0)),
            "max": flat(np.nanmax(sst, axis=0)),
            "std": flat(np.nanstd(sst, axis=0)),
            "mean_1_4": flat(np.nanmean(sst[1:5], axis=0)),
            "anomaly": flat(sst[3] - np.nanmean(sst, axis=0)),
            "vol_diff": flat((t64[1] - t64[0]).astype(np.float32)),
            "vol_mean": flat(np.nanmean(t64, axis=0).astype(np.float32)),
        }
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1])
