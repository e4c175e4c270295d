#!/usr/bin/env python3
"""Write a CF NetCDF field on (depth, latitude, longitude) the way a user's xarray script does:
NetCDF-4 with zlib compression, CF attributes on the coordinates.

    python3 tests/python/write_cf_sphere.py OUT.nc KIND [options]

KIND:
  shell      value 1 everywhere (a constant shell)
  radial     value = radius in km (linear in radius)
  lonfield   value = 2 + cos(lon) * cos(lat) + 0.1 * depth index (smooth, no seam)
  ocean      a Cartesian box (x, y in m, no latitude/longitude) on stretched depth levels
             (quadratic, positive down, m); value = depth: a rectilinear volume
Options:
  --lon0 L         first cell edge of the longitudes (-180 or 0; default -180)
  --nlat N --nlon N --ndepth N   (defaults 36, 72, 8)
  --depth-top D --depth-bottom D (km; defaults 0 and 2891)
  --uneven         depth levels spaced quadratically (irregular, as tomography models)
  --wedge LAT0 LAT1 LON0 LON1    a regional grid whose cell edges are these (degrees)
  --order ORDER    dimension order, e.g. "depth,latitude,longitude" (default) or
                   "latitude,longitude,depth"
  --no-units       leave the depth axis without units (a bad file)
  --radius R       write the global attribute planet_radius = R (km)
  --bad-lat        shift the latitudes north so the last one is beyond 90 (a bad file)
  --dup-depth      repeat the first depth level (a bad file)
Exit status 77 (skipped) when numpy or xarray is not installed.
"""

import argparse
import sys

try:
    import netCDF4  # noqa: F401  (xarray's NetCDF-4 writer; without it to_netcdf fails)
    import numpy as np
    import xarray as xr
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install numpy xarray netCDF4)", file=sys.stderr)
    sys.exit(77)

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("kind", choices=["shell", "radial", "lonfield", "ocean"])
ap.add_argument("--lon0", type=float, default=-180.0)
ap.add_argument("--nlat", type=int, default=36)
ap.add_argument("--nlon", type=int, default=72)
ap.add_argument("--ndepth", type=int, default=8)
ap.add_argument("--depth-top", type=float, default=0.0)
ap.add_argument("--depth-bottom", type=float, default=2891.0)
ap.add_argument("--uneven", action="store_true")
ap.add_argument("--wedge", type=float, nargs=4)
ap.add_argument("--order", default="depth,latitude,longitude")
ap.add_argument("--no-units", action="store_true")
ap.add_argument("--radius", type=float)
ap.add_argument("--bad-lat", action="store_true")
ap.add_argument("--dup-depth", action="store_true")
a = ap.parse_args()

if a.kind == "ocean":
    depth = 10.0 * np.arange(a.ndepth) ** 2 + 5.0
    y = 100.0 * np.arange(6)
    x = 100.0 * np.arange(5)
    dd = np.broadcast_to(depth[:, None, None], (a.ndepth, 6, 5)).astype(np.float32)
    ds = xr.Dataset(
        {"temp": (("depth", "y", "x"), dd, {"units": "m"})},
        coords={
            "depth": ("depth", depth, {"units": "m", "positive": "down"}),
            "y": ("y", y, {"units": "m"}),
            "x": ("x", x, {"units": "m"}),
        },
    )
    ds.to_netcdf(a.out, format="NETCDF4")
    sys.exit(0)

R = a.radius if a.radius else 6371.0
if a.uneven:
    s = np.linspace(0.0, 1.0, a.ndepth) ** 2
    depth = a.depth_top + (a.depth_bottom - a.depth_top) * s
else:
    depth = np.linspace(a.depth_top, a.depth_bottom, a.ndepth)
if a.wedge:
    lat0, lat1, lon0, lon1 = a.wedge
    dlat = (lat1 - lat0) / a.nlat
    dlon = (lon1 - lon0) / a.nlon
    lat = lat0 + dlat * (np.arange(a.nlat) + 0.5)
    lon = lon0 + dlon * (np.arange(a.nlon) + 0.5)
    lat_bounds = np.stack([lat - dlat / 2, lat + dlat / 2], axis=1)
    lon_bounds = np.stack([lon - dlon / 2, lon + dlon / 2], axis=1)
else:
    lat = -90.0 + 180.0 / a.nlat * (np.arange(a.nlat) + 0.5)
    lon = a.lon0 + 360.0 / a.nlon * (np.arange(a.nlon) + 0.5)
    lat_bounds = lon_bounds = None

if a.bad_lat:
    lat = lat + 25.0
if a.dup_depth:
    depth[1] = depth[0]
dd, la, lo = np.meshgrid(depth, lat, lon, indexing="ij")
if a.kind == "shell":
    v = np.ones(dd.shape)
elif a.kind == "radial":
    v = R - dd
else:
    v = 2.0 + np.cos(np.radians(lo)) * np.cos(np.radians(la)) + 0.1 * np.arange(a.ndepth)[:, None, None]

order = a.order.split(",")
axes = {"depth": 0, "latitude": 1, "longitude": 2}
v = np.transpose(v, [axes[d] for d in order]).astype(np.float32)
depth_attrs = {"standard_name": "depth", "positive": "down", "long_name": "depth below surface"}
if not a.no_units:
    depth_attrs["units"] = "km"
coords = {
    "depth": ("depth", depth, depth_attrs),
    "latitude": ("latitude", lat, {"units": "degrees_north", "standard_name": "latitude"}),
    "longitude": ("longitude", lon, {"units": "degrees_east", "standard_name": "longitude"}),
}
data_vars = {"dvs": (tuple(order), v, {"units": "percent", "long_name": "test field"})}
if lat_bounds is not None:
    coords["latitude"][2]["bounds"] = "lat_bnds"
    coords["longitude"][2]["bounds"] = "lon_bnds"
    data_vars["lat_bnds"] = (("latitude", "nv"), lat_bounds)
    data_vars["lon_bnds"] = (("longitude", "nv"), lon_bounds)
ds = xr.Dataset(data_vars, coords=coords)
if a.radius:
    ds.attrs["planet_radius"] = a.radius
ds.attrs["Conventions"] = "CF-1.8"
encoding = {"dvs": {"zlib": True, "complevel": 4}}
try:
    ds.to_netcdf(a.out, format="NETCDF4", encoding=encoding)
except (ImportError, ValueError) as exc:  # no NetCDF engine installed
    print(f"SKIP: {exc}", file=sys.stderr)
    sys.exit(77)
