#!/usr/bin/env python3
"""Write a CF NetCDF field on (latitude, longitude) the way a user's xarray script does:
NetCDF-4 with zlib compression, CF attributes on the coordinates, nodes on cell centres.

    python3 tests/python/write_cf_latlon.py OUT.nc [options]

The field is d = 2 * latitude + 0.1 * longitude (degrees), named `eta`, units m.
Options:
  --lat LAT0 LAT1 N   cell edges and count of the latitudes (default 30 60 30)
  --lon LON0 LON1 N   cell edges and count of the longitudes (default 0 90 90)
  --descending        store latitudes north to south, as many gridded products do
  --bad-lat           make the last latitude 91 (a bad file)
Exit status 77 (skipped) when numpy or xarray is not installed.
"""

import argparse
import sys

try:
    import numpy as np
    import xarray as xr
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install numpy xarray netCDF4)", file=sys.stderr)
    sys.exit(77)

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--lat", type=float, nargs=3, default=[30.0, 60.0, 30])
ap.add_argument("--lon", type=float, nargs=3, default=[0.0, 90.0, 90])
ap.add_argument("--descending", action="store_true")
ap.add_argument("--bad-lat", action="store_true")
a = ap.parse_args()


def centres(lo, hi, n):
    n = int(n)
    return lo + (hi - lo) / n * (np.arange(n) + 0.5)


lat = centres(*a.lat)
lon = centres(*a.lon)
if a.bad_lat:
    lat[-1] = 91.0
if a.descending:
    lat = lat[::-1]
la, lo = np.meshgrid(lat, lon, indexing="ij")
eta = (2.0 * la + 0.1 * lo).astype(np.float32)
ds = xr.Dataset(
    {"eta": (("latitude", "longitude"), eta, {"units": "m", "long_name": "test field"})},
    coords={
        "latitude": ("latitude", lat, {"units": "degrees_north", "standard_name": "latitude"}),
        "longitude": ("longitude", lon, {"units": "degrees_east", "standard_name": "longitude"}),
    },
)
ds.attrs["Conventions"] = "CF-1.8"
try:
    ds.to_netcdf(a.out, format="NETCDF4", encoding={"eta": {"zlib": True, "complevel": 4}})
except (ImportError, ValueError) as exc:  # no NetCDF engine installed
    print(f"SKIP: {exc}", file=sys.stderr)
    sys.exit(77)
