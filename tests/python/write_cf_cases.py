#!/usr/bin/env python3
"""Write NetCDF files as real data comes (netCDF4 and xarray as users call them) and print, as
text, what netCDF4-python, cftime and xarray make of them: the reference values of hdrvis's
tests of default fill values, auxiliary variables, wrapped longitudes, CF time and selection.

    python3 tests/python/write_cf_cases.py OUT_DIR CASE

CASE is one of:
  fills     fills.nc: netCDF4 variables without _FillValue, partly unwritten or holding netCDF's
            default fill values; masked counts, maxima and values as netCDF4-python masks them
  aux       aux.nc: xarray, a 3-D field `temp` with 2-D auxiliary latitude/longitude, a grid
            mapping, bounds and an ancillary variable written before it
  wrapped   wrapped.nc: xarray, (depth, lat, lon) and (lat, lon) fields on a 40 degree region
            across the prime meridian, longitudes stored 322.5 .. 357.5, 2.5; sorted.nc: the
            same fields on the region 160 .. 205 E across the antimeridian, longitudes stored in
            numeric order in [-180, 180) (-177.5 .. -157.5, 162.5 .. 177.5) with CF bounds, and
            the fields in geographic order (xarray's roll) with the longitudes unwrapped
  series    series360.nc (360_day, negative times) and series_gregorian.nc (standard calendar
            across the 1582 reform): (time, depth, lat, lon) and (time, lat, lon) fields, with
            cftime's dates and xarray's isel/sel/interp values; series_badcal.nc with the
            calendar "lunar"
  levels    levels.nc: xarray, a (level, lat, lon) field on model levels (units "1") with an
            auxiliary level_height in metres, and a (plev, lat, lon) one on pressure levels (hPa,
            positive down, stored 1000 .. 100); xarray's values and isel/sel of each
  rotated   rotated.nc: xarray, a EURO-CORDEX-like rotated-pole grid (rotated_latitude_longitude,
            pole 39.25N 162W) with CORDEX's 2-D auxiliary lat/lon and a field `tlat` holding each
            node's true latitude; the rotated axes and each node's true latitude and longitude as
            pyproj (PROJ's ob_tran, CRS.from_cf) computes them
  rotated3d rotated3d.nc: xarray, a (depth, rlat, rlon) volume on the EURO-CORDEX-like rotated
            grid of `rotated`: `blob`, a Gaussian 2 degrees wide about the true point 50N 10E (by
            pyproj's node positions), and `tlat`, each node's true latitude; the blob centre's
            rotated coordinates
  curvilinear curvilinear.nc: xarray, an ocean-model-like curvilinear grid (2-D lat/lon as
            coordinates, sheared and bent, across the antimeridian with longitudes stored in
            [-180, 180)) holding a smooth field `sst` with one missing node and `lin`, linear in
            latitude and unwrapped longitude; the regular 0.5-degree nodes and the values on them
            of linear interpolation over the grid's triangles, computed here with numpy
  movie     tsunami_series.nc by datasets/fixtures/make_series.py (xarray): eta's range over every
            step, its 2nd and 98th percentiles (numpy's nanpercentile, as xarray's robust plots)
            over steps 1, 3 and 5, and the time axis's dates
Each result is one line, `KEY VALUE VALUE ...`, nested keys joined by dots, arrays in C order
with `nan` for masked values. Exit status 77 (skipped) when a module is missing.
"""

import os
import sys

try:
    import cftime
    import netCDF4
    import numpy as np
    import xarray as xr
    import scipy  # noqa: F401  (xarray's interp uses it)
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)


def values(a):
    """Masked or NaN values as None, the rest as floats, in C order."""
    a = np.ma.masked_invalid(np.ma.asarray(a, dtype=np.float64))
    return [float("nan") if m else float(v) for v, m in zip(a.ravel().data, np.ma.getmaskarray(a).ravel())]


def emit(prefix, value):
    """Prints a nested result as `KEY VALUE ...` lines."""
    if isinstance(value, dict):
        for k, v in value.items():
            emit(f"{prefix}.{k}" if prefix else k, v)
        return
    items = value if isinstance(value, list) else [value]
    print(prefix, *(repr(v) if isinstance(v, float) else str(v) for v in items))


def fills(out):
    path = os.path.join(out, "fills.nc")
    with netCDF4.Dataset(path, "w", format="NETCDF4") as d:
        for name, n in (("z", 2), ("y", 3), ("x", 4)):
            d.createDimension(name, n)
        t = d.createVariable("t", "f4", ("z", "y", "x"))
        t.units = "K"
        # Only the first level is written: the second reads as the default fill everywhere.
        t[0, :, :] = np.arange(12, dtype=np.float32).reshape(3, 4) + 0.5
        n = d.createVariable("n", "i4", ("y", "x"))
        counts = np.arange(12, dtype=np.int32).reshape(3, 4) * 100
        counts[1, 2] = netCDF4.default_fillvals["i4"]
        n[:] = counts
        s = d.createVariable("s", "i2", ("y", "x"))
        s.missing_value = np.int16(-1)
        levels = np.arange(12, dtype=np.int16).reshape(3, 4)
        levels[0, 1] = -1
        levels[2, 3] = netCDF4.default_fillvals["i2"]
        s[:] = levels
        u = d.createVariable("u", "u1", ("y", "x"))
        u[:] = np.array([[1, 2, 255, 4], [5, 6, 7, 8], [9, 10, 11, 12]], dtype=np.uint8)
    result = {}
    with netCDF4.Dataset(path) as d:
        for name in ("t", "n", "s", "u"):
            a = d[name][:]
            result[name] = {
                "masked": int(np.ma.count_masked(a)),
                "max": float(a.max()),
                "values": values(a),
            }
    return result


def aux(out):
    path = os.path.join(out, "aux.nc")
    nz, ny, nx = 3, 4, 5
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    lat = 40.0 + 0.5 * j + 0.1 * i
    lon = 10.0 + 0.6 * i - 0.05 * j
    temp = (np.arange(nz * ny * nx, dtype=np.float32).reshape(nz, ny, nx) * 0.25)
    qc = np.ones((nz, ny, nx), dtype=np.int8)
    ds = xr.Dataset(
        {
            "qc": (("z", "y", "x"), qc, {"long_name": "quality flag"}),
            "temp": (
                ("z", "y", "x"),
                temp,
                {"units": "degC", "grid_mapping": "crs", "ancillary_variables": "qc"},
            ),
            "crs": ((), np.int32(0), {"grid_mapping_name": "latitude_longitude"}),
            "z_bnds": (("z", "nv"), np.array([[0, 10], [10, 20], [20, 30]], dtype=np.float64)),
        },
        coords={
            "latitude": (("y", "x"), lat, {"units": "degrees_north", "standard_name": "latitude"}),
            "longitude": (("y", "x"), lon, {"units": "degrees_east", "standard_name": "longitude"}),
            "z": ("z", [5.0, 15.0, 25.0], {"units": "m", "bounds": "z_bnds", "positive": "up"}),
        },
    )
    ds.to_netcdf(path, format="NETCDF4")
    with netCDF4.Dataset(path) as d:
        order = list(d.variables)
        coordinates = d["temp"].coordinates
    return {"order": order, "coordinates": coordinates, "temp": values(temp)}


def wrapped(out):
    path = os.path.join(out, "wrapped.nc")
    lon = (322.5 + 5.0 * np.arange(9)) % 360.0
    lat = np.array([40.0, 45.0, 50.0, 55.0])
    depth = np.array([10.0, 20.0, 40.0])
    unwrapped = lon + 360.0 * np.concatenate([[0], np.cumsum(np.diff(lon) < 0)])
    d3, la3, lo3 = np.meshgrid(depth, lat, unwrapped, indexing="ij")
    field = (d3 + 0.5 * la3 + 0.01 * lo3).astype(np.float32)
    ds = xr.Dataset(
        {
            "rho": (("depth", "lat", "lon"), field, {"units": "kg m-3"}),
            "eta": (("lat", "lon"), field[0] * 2.0, {"units": "m"}),
        },
        coords={
            "depth": ("depth", depth, {"units": "km", "positive": "down"}),
            "lat": ("lat", lat, {"units": "degrees_north", "standard_name": "latitude"}),
            "lon": ("lon", lon, {"units": "degrees_east", "standard_name": "longitude"}),
        },
    )
    ds.to_netcdf(path, format="NETCDF4")
    with xr.open_dataset(path) as x:
        result = {
            "lon": [float(v) for v in x.lon.values],
            "unwrapped": [float(v) for v in unwrapped],
            "eta": values(x.eta.values),
            "rho": values(x.rho.values),
        }
    # The region 160 .. 205 degrees east across the antimeridian, stored in numeric order in
    # [-180, 180) with CF bounds, as a sorted longitude axis leaves it; the reference is the
    # geographic order (xarray's roll) with longitudes unwrapped east of 180.
    true = 162.5 + 5.0 * np.arange(9)
    stored = np.where(true >= 180.0, true - 360.0, true)
    order = np.argsort(stored)
    d3, la3, lo3 = np.meshgrid(depth, lat, true, indexing="ij")
    field = (d3 + 0.5 * la3 + 0.01 * lo3).astype(np.float32)
    sorted_ds = xr.Dataset(
        {
            "rho": (("depth", "lat", "lon"), field[..., order], {"units": "kg m-3"}),
            "eta": (("lat", "lon"), field[0][..., order] * 2.0, {"units": "m"}),
            "lon_bnds": (("lon", "nv"), np.stack([stored[order] - 2.5, stored[order] + 2.5], -1)),
        },
        coords={
            "depth": ("depth", depth, {"units": "km", "positive": "down"}),
            "lat": ("lat", lat, {"units": "degrees_north", "standard_name": "latitude"}),
            "lon": ("lon", stored[order], {"units": "degrees_east", "bounds": "lon_bnds"}),
        },
    )
    sorted_path = os.path.join(out, "sorted.nc")
    sorted_ds.to_netcdf(sorted_path, format="NETCDF4")
    with xr.open_dataset(sorted_path) as x:
        start = int(np.argmax(np.diff(x.lon.values))) + 1
        geo = x.roll(lon=-start, roll_coords=True)
        lon = geo.lon.values
        result["sorted"] = {
            "stored": [float(v) for v in x.lon.values],
            "unwrapped": [float(v) for v in np.where(lon < lon[0], lon + 360.0, lon)],
            "eta": values(geo.eta.values),
            "rho": values(geo.rho.values),
            "eta_lon4": values(geo.eta.isel(lon=4).values),
        }
    return result


def iso(date):
    return date.strftime("%Y-%m-%dT%H:%M:%S")


def series_file(path, units, calendar, times, depth, lat, lon):
    """A (time, depth, lat, lon) field `temp` and a (time, lat, lon) field `tas`, by netCDF4."""
    nt, nz, ny, nx = len(times), len(depth), len(lat), len(lon)
    with netCDF4.Dataset(path, "w", format="NETCDF4") as d:
        for name, n in (("time", None), ("depth", nz), ("lat", ny), ("lon", nx)):
            d.createDimension(name, n)
        t = d.createVariable("time", "f8", ("time",))
        t.units, t.calendar, t.standard_name, t.axis = units, calendar, "time", "T"
        t[:] = times
        for name, vals, attrs in (
            ("depth", depth, {"units": "m", "positive": "down"}),
            ("lat", lat, {"units": "degrees_north", "standard_name": "latitude"}),
            ("lon", lon, {"units": "degrees_east", "standard_name": "longitude"}),
        ):
            v = d.createVariable(name, "f8", (name,))
            v.setncatts(attrs)
            v[:] = vals
        ti, zi, yi, xi = np.meshgrid(
            np.arange(nt), np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij"
        )
        temp = d.createVariable("temp", "f4", ("time", "depth", "lat", "lon"))
        temp.units = "degC"
        temp[:] = 1000.0 * ti + 100.0 * zi + 10.0 * yi + xi
        tas = d.createVariable("tas", "f4", ("time", "lat", "lon"))
        tas.units = "K"
        tas[:] = 250.0 + ti[:, 0] + 0.5 * yi[:, 0] + 0.25 * xi[:, 0]
    with netCDF4.Dataset(path) as d:
        t = d["time"]
        dates = netCDF4.num2date(t[:], t.units, t.calendar)
    return [iso(x) for x in dates]


def series(out):
    depth = np.array([0.0, 100.0, 300.0, 600.0])
    lat = np.array([-10.0, 0.0, 10.0])
    lon = np.array([100.0, 110.0, 120.0, 130.0, 140.0])
    result = {}
    cases = (
        ("series360", "days since 2000-01-01 00:00:00", "360_day",
         [-45.0, -15.0, 15.0, 45.5, 75.0, 105.25], cftime.Datetime360Day(1999, 12, 3, 6)),
        ("series_gregorian", "hours since 1582-10-15 00:00", "standard",
         [-48.0, -24.0, 0.0, 24.0, 8772.0, 8790.0], cftime.DatetimeGregorian(1583, 10, 15, 7)),
    )
    for name, units, calendar, times, near in cases:
        path = os.path.join(out, name + ".nc")
        dates = series_file(path, units, calendar, times, depth, lat, lon)
        coder = xr.coders.CFDatetimeCoder(use_cftime=True)
        with xr.open_dataset(path, decode_times=coder) as x:
            result[name] = {
                "first": dates[0],
                "last": dates[-1],
                "dates": dates,
                "calendar": calendar,
                "near": iso(near),
                "near_index": int(
                    np.argmin(np.abs(np.asarray(times) - cftime.date2num(near, units, calendar)))
                ),
                "isel_time2": values(x.temp.isel(time=2).values),
                "sel_near_tas": values(x.tas.sel(time=near, method="nearest").values),
                "isel_time1_depth600": values(x.temp.isel(time=1).sel(depth=600.0).values),
                "interp_time1_depth200": values(x.temp.isel(time=1).interp(depth=200.0).values),
            }
    # The 360_day file with a calendar CF does not define.
    bad = os.path.join(out, "series_badcal.nc")
    with netCDF4.Dataset(bad, "w", format="NETCDF4") as d:
        d.createDimension("time", 2)
        d.createDimension("x", 3)
        t = d.createVariable("time", "f8", ("time",))
        t.units, t.calendar = "days since 2000-01-01", "lunar"
        t[:] = [0.0, 1.0]
        d.createVariable("v", "f4", ("time", "x"))[:] = np.zeros((2, 3))
    return result


def movie(out):
    here = os.path.dirname(os.path.abspath(__file__))
    sys.path.insert(0, os.path.join(here, "..", "..", "datasets", "fixtures"))
    import make_series

    path = os.path.join(out, "tsunami_series.nc")
    make_series.main(path)
    eta = xr.open_dataset(path).eta
    some = eta.isel(time=[1, 3, 5]).values
    return {
        "min": float(eta.min()),
        "max": float(eta.max()),
        "robust": [float(v) for v in np.nanpercentile(some, [2.0, 98.0])],
        "dates": [str(d)[:19] for d in eta.time.values],
    }


def levels(out):
    rng = np.random.default_rng(5)
    lat = np.linspace(-87.0, 87.0, 7)
    lon = np.arange(12) * 30.0
    geo = {"lat": ("lat", lat, {"units": "degrees_north"}), "lon": ("lon", lon, {"units": "degrees_east"})}
    level = xr.DataArray(np.arange(1, 6), dims="level", attrs={"units": "1", "axis": "Z", "positive": "up", "long_name": "model level number"})
    height = xr.DataArray([20.0, 500.0, 2000.0, 8000.0, 20000.0], dims="level", attrs={"units": "m", "long_name": "height of the level above the surface"})
    ta = xr.DataArray(rng.random((5, 7, 12)).astype("f4"), dims=("level", "lat", "lon"), name="ta")
    model = xr.Dataset({"ta": ta}, coords={"level": level, "level_height": height, **geo})
    model.to_netcdf(os.path.join(out, "model_levels.nc"))
    plev = xr.DataArray([1000.0, 850.0, 500.0, 250.0, 100.0], dims="plev", attrs={"units": "hPa", "positive": "down", "standard_name": "air_pressure"})
    u = xr.DataArray(rng.random((5, 7, 12)).astype("f4"), dims=("plev", "lat", "lon"), name="u")
    pressure = xr.Dataset({"u": u}, coords={"plev": plev, **geo})
    pressure.to_netcdf(os.path.join(out, "pressure_levels.nc"))
    return {
        "ta": values(model.ta.values),
        "height": [float(h) for h in height.values],
        "ta_level3": values(model.ta.isel(level=3).values),
        "u": values(pressure.u.values),
        "u_500": values(pressure.u.sel(plev=500.0).values),
    }


def rotated(out):
    import pyproj

    path = os.path.join(out, "rotated.nc")
    mapping = {
        "grid_mapping_name": "rotated_latitude_longitude",
        "grid_north_pole_latitude": 39.25,
        "grid_north_pole_longitude": -162.0,
    }
    rlat = np.arange(-12.0, 12.01, 0.5)
    rlon = np.arange(-16.0, 16.01, 0.5)
    rlon2, rlat2 = np.meshgrid(rlon, rlat)
    to_true = pyproj.Transformer.from_crs(pyproj.CRS.from_cf(mapping), "EPSG:4326", always_xy=True)
    tlon, tlat = to_true.transform(rlon2, rlat2)
    field = {"grid_mapping": "rotated_pole", "coordinates": "lat lon"}
    ds = xr.Dataset(
        {
            "tas": (("rlat", "rlon"), (280.0 + 0.1 * rlat2).astype(np.float32), dict(field, units="K")),
            "tlat": (("rlat", "rlon"), tlat, dict(field, units="degrees")),
            "rotated_pole": ((), np.int32(0), mapping),
        },
        coords={
            "rlat": ("rlat", rlat, {"standard_name": "grid_latitude", "units": "degrees", "axis": "Y"}),
            "rlon": ("rlon", rlon, {"standard_name": "grid_longitude", "units": "degrees", "axis": "X"}),
            "lat": (("rlat", "rlon"), tlat, {"standard_name": "latitude", "units": "degrees_north"}),
            "lon": (("rlat", "rlon"), tlon, {"standard_name": "longitude", "units": "degrees_east"}),
        },
    )
    ds.to_netcdf(path, format="NETCDF4")
    return {"rlat": [float(v) for v in rlat], "rlon": [float(v) for v in rlon],
            "tlat": values(tlat), "tlon": values(tlon)}


def rotated3d(out):
    import pyproj

    path = os.path.join(out, "rotated3d.nc")
    mapping = {
        "grid_mapping_name": "rotated_latitude_longitude",
        "grid_north_pole_latitude": 39.25,
        "grid_north_pole_longitude": -162.0,
    }
    rlat = np.arange(-12.0, 12.01, 0.5)
    rlon = np.arange(-16.0, 16.01, 0.5)
    depth = np.array([0.0, 200.0, 400.0, 600.0])
    rlon2, rlat2 = np.meshgrid(rlon, rlat)
    crs = pyproj.CRS.from_cf(mapping)
    tlon, tlat = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(rlon2, rlat2)
    geod = pyproj.Geod(a=1.0, b=1.0)
    _, _, dist = geod.inv(tlon, tlat, np.full_like(tlon, 10.0), np.full_like(tlat, 50.0))
    blob = np.exp(-(np.degrees(dist) / 2.0) ** 2)
    field = {"grid_mapping": "rotated_pole", "coordinates": "lat lon"}
    layers = lambda a: np.repeat(a[None, :, :], len(depth), axis=0)
    ds = xr.Dataset(
        {
            "blob": (("depth", "rlat", "rlon"), layers(blob), dict(field, units="1")),
            "tlat": (("depth", "rlat", "rlon"), layers(tlat), dict(field, units="degrees")),
            "rotated_pole": ((), np.int32(0), mapping),
        },
        coords={
            "depth": ("depth", depth, {"units": "km", "positive": "down", "standard_name": "depth"}),
            "rlat": ("rlat", rlat, {"standard_name": "grid_latitude", "units": "degrees", "axis": "Y"}),
            "rlon": ("rlon", rlon, {"standard_name": "grid_longitude", "units": "degrees", "axis": "X"}),
            "lat": (("rlat", "rlon"), tlat, {"standard_name": "latitude", "units": "degrees_north"}),
            "lon": (("rlat", "rlon"), tlon, {"standard_name": "longitude", "units": "degrees_east"}),
        },
    )
    ds.to_netcdf(path, format="NETCDF4")
    brlon, brlat = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(10.0, 50.0)
    return {"blob_rotated": [float(brlat), float(brlon)]}


def curvilinear(out):
    path = os.path.join(out, "curvilinear.nc")
    ny, nx = 24, 36
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    x, y = 0.8 * i, 0.8 * j
    th = np.radians(25.0)
    ulon = 165.0 + x * np.cos(th) - y * np.sin(th) + 0.01 * x * x
    lat = -30.0 + x * np.sin(th) + y * np.cos(th) + 0.005 * y * y
    lon = (ulon + 180.0) % 360.0 - 180.0
    sst = 20.0 + 5.0 * np.sin(np.radians(3.0 * lat)) * np.cos(np.radians(2.0 * ulon))
    sst[10, 15] = np.nan
    lin = 0.1 * lat + 0.05 * ulon
    ds = xr.Dataset(
        {"sst": (("nj", "ni"), sst, {"units": "degC"}), "lin": (("nj", "ni"), lin, {"units": "1"})},
        coords={
            "lat": (("nj", "ni"), lat, {"standard_name": "latitude", "units": "degrees_north"}),
            "lon": (("nj", "ni"), lon, {"standard_name": "longitude", "units": "degrees_east"}),
        },
    )
    ds.to_netcdf(path, format="NETCDF4")
    # The regular nodes and linear interpolation over the triangles (k, k+1, k+nx+1) and
    # (k, k+nx+1, k+nx) of each cell, missing where a corner is or no triangle covers a node.
    step = 0.5
    def axis(v):
        n = int(np.floor((v.max() - v.min()) / step + 1e-9)) + 1
        return v.min() + step * np.arange(n)
    rlon, rlat = axis(ulon), axis(lat)
    px, py = np.meshgrid(rlon, rlat)
    result = {}
    for name, field in (("sst", sst), ("lin", lin)):
        got = np.full(px.shape, np.nan)
        done = np.zeros(px.shape, dtype=bool)
        P, V = np.stack([ulon.ravel(), lat.ravel()], 1), field.ravel()
        for jj in range(ny - 1):
            for ii in range(nx - 1):
                k = jj * nx + ii
                for tri in ((k, k + 1, k + nx + 1), (k, k + nx + 1, k + nx)):
                    a, b, c = P[list(tri)]
                    area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
                    wb = ((px - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (py - a[1])) / area
                    wc = ((b[0] - a[0]) * (py - a[1]) - (px - a[0]) * (b[1] - a[1])) / area
                    wa = 1.0 - wb - wc
                    inside = (wa >= -1e-12) & (wb >= -1e-12) & (wc >= -1e-12) & ~done
                    got[inside] = (wa * V[tri[0]] + wb * V[tri[1]] + wc * V[tri[2]])[inside]
                    done |= inside
        result[name] = values(got)
    result.update({"lon": [float(v) for v in rlon], "lat": [float(v) for v in rlat]})
    return result


def main():
    out, case = sys.argv[1], sys.argv[2]
    run = {"fills": fills, "aux": aux, "wrapped": wrapped, "series": series, "movie": movie, "levels": levels,
           "rotated": rotated, "rotated3d": rotated3d, "curvilinear": curvilinear}[case]
    emit("", run(out))


main()
