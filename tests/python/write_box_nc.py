#!/usr/bin/env python3
"""Write a NetCDF box with several variables the way a user's xarray script does.

    python3 tests/python/write_box_nc.py OUT.nc

Dimensions z=5, y=25, x=20 on evenly spaced coordinates; variables T = 1 + x (varies along x),
S = 100 + y (varies along y) and mask (int8), so a reader that picks the wrong variable gets
different numbers. Exit status 77 (skipped) when numpy or xarray is not installed.
"""

import sys

try:
    import numpy as np
    import xarray as xr
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install numpy xarray netCDF4)", file=sys.stderr)
    sys.exit(77)

z = np.arange(5, dtype=np.float64)
y = np.arange(25, dtype=np.float64)
x = np.arange(20, dtype=np.float64)
zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
ds = xr.Dataset(
    {
        "T": (("z", "y", "x"), (1.0 + xx).astype(np.float32), {"units": "degC"}),
        "S": (("z", "y", "x"), (100.0 + yy).astype(np.float32), {"units": "psu"}),
        "mask": (("z", "y", "x"), np.ones(zz.shape, dtype=np.int8)),
    },
    coords={"z": z, "y": y, "x": x},
)
try:
    ds.to_netcdf(sys.argv[1])
except (ImportError, ValueError) as exc:  # no NetCDF engine installed
    print(f"SKIP: {exc}", file=sys.stderr)
    sys.exit(77)
