#!/usr/bin/env python3
"""Write NetCDF files shaped as climate archives write them (netCDF4-python, with the variables,
types and attributes CORDEX, CMIP5 and old NetCDF-3 examples carry) and print what xarray's
`isel` reads from them: the reference values of hdrvis's tests of archive files.

    python3 tests/python/write_archive_cases.py OUT_DIR CASE

CASE is one of:
  cordex    tas_EUR-11_cordex.nc: tas(time, rlat, rlon) on a rotated-pole grid whose grid-mapping
            variable is `char rotated_pole` (an attribute container, as every CORDEX file has it),
            2-D auxiliary lat/lon, a scalar `height` of 2 m, time bounds
  cmip      tas_Amon_cmip.nc: CMIP5's tas(time, lat, lon) with a scalar `height` coordinate (2 m);
            tas_height.nc: the same field as tas(time, height, lat, lon) on a size-1 height axis
  months    months.nc: a series on `months since 1958-1-1` in the 360_day calendar (cftime
            decodes it) and months_std.nc in the standard calendar (xarray leaves it as numbers)
  absolute  absolute_time.nc: ICON/CDO output whose time axis is `day as %Y%m%d.%f` (absolute
            dates, 20240115.25 for 06:00 on 15 January 2024), which xarray leaves as numbers; the
            dates as CDO defines them (the digits are the date, the fraction the time of day)
  nat       all_missing_time.nc: a field whose `time` coordinate holds only _FillValue
  longhdr   long_header.nc: NetCDF-3 classic with 100 kB of text attributes before the variables
            (the header is longer than a first read of 64 KiB)
  h5dims    dims.h5: h5py's dimension scales (time in days since 2000-01-01, noleap; lat; lon)
            attached to a float32 t2m with missing_value, as h5netcdf lays files out; xarray's
            isel(time=1) and dates
  groups    groups.nc: NetCDF-4 with a root time axis and the data in groups, as satellite
            products keep it (/PRODUCT/ch4, /PRODUCT/SUPPORT_DATA/qa)
  h5cf      cf.h5: a plain HDF5 dataset written by h5py with CF's packing and masking attributes
            (int16, _FillValue, scale_factor, add_offset, valid_range); the values as
            netCDF4-python (netCDF-C) and xarray decode it
Each result is one line, `KEY VALUE VALUE ...`, arrays in C order with `nan` for missing values.
Exit status 77 (skipped) when a module is missing.
"""

import os
import sys

try:
    import netCDF4
    import numpy as np
    import xarray as xr
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)


def emit(key, values):
    flat = np.asarray(values, dtype=float).ravel()
    print(key, " ".join("nan" if np.isnan(v) else repr(float(v)) for v in flat))


def field(nt, ny, nx, seed):
    """A smooth field of temperatures in kelvin with a different pattern at each step."""
    t, y, x = np.meshgrid(np.arange(nt), np.arange(ny), np.arange(nx), indexing="ij")
    rng = np.random.default_rng(seed)
    return (280.0 + 10.0 * np.sin(0.4 * x + 0.7 * t) * np.cos(0.3 * y) + rng.normal(0, 0.1, t.shape)).astype("f4")


def cordex(out):
    path = os.path.join(out, "tas_EUR-11_cordex.nc")
    nt, ny, nx = 3, 8, 10
    with netCDF4.Dataset(path, "w", format="NETCDF4_CLASSIC") as ds:
        ds.Conventions = "CF-1.4"
        ds.project_id = "CORDEX"
        ds.CORDEX_domain = "EUR-11"
        ds.createDimension("time", None)
        ds.createDimension("bnds", 2)
        ds.createDimension("rlat", ny)
        ds.createDimension("rlon", nx)
        time = ds.createVariable("time", "f8", ("time",))
        time.units = "days since 1949-12-01 00:00:00"
        time.calendar = "standard"
        time.standard_name = "time"
        time.axis = "T"
        time.bounds = "time_bnds"
        time[:] = 20454.5 + 30.0 * np.arange(nt)
        tb = ds.createVariable("time_bnds", "f8", ("time", "bnds"))
        tb[:] = np.stack([time[:] - 15, time[:] + 15], axis=1)
        rlat = ds.createVariable("rlat", "f8", ("rlat",))
        rlat.standard_name = "grid_latitude"
        rlat.units = "degrees"
        rlat.axis = "Y"
        rlat[:] = -5.0 + 0.11 * np.arange(ny)
        rlon = ds.createVariable("rlon", "f8", ("rlon",))
        rlon.standard_name = "grid_longitude"
        rlon.units = "degrees"
        rlon.axis = "X"
        rlon[:] = -8.0 + 0.11 * np.arange(nx)
        pole = ds.createVariable("rotated_pole", "S1")
        pole.grid_mapping_name = "rotated_latitude_longitude"
        pole.grid_north_pole_latitude = 39.25
        pole.grid_north_pole_longitude = -162.0
        lat = ds.createVariable("lat", "f8", ("rlat", "rlon"))
        lat.standard_name = "latitude"
        lat.units = "degrees_north"
        lon = ds.createVariable("lon", "f8", ("rlat", "rlon"))
        lon.standard_name = "longitude"
        lon.units = "degrees_east"
        # Placeholder positions near the domain's centre; hdrvis places nodes by the pole.
        lat[:] = 50.0 + 0.11 * np.arange(ny)[:, None] + 0.0 * np.arange(nx)
        lon[:] = 10.0 + 0.0 * np.arange(ny)[:, None] + 0.11 * np.arange(nx)
        height = ds.createVariable("height", "f8")
        height.units = "m"
        height.axis = "Z"
        height.positive = "up"
        height.standard_name = "height"
        height.assignValue(2.0)
        tas = ds.createVariable("tas", "f4", ("time", "rlat", "rlon"), fill_value=np.float32(1e20))
        tas.standard_name = "air_temperature"
        tas.units = "K"
        tas.coordinates = "lon lat height"
        tas.grid_mapping = "rotated_pole"
        data = field(nt, ny, nx, 1)
        data[1, 2, 3] = 1e20
        tas[:] = data
    ds = xr.open_dataset(path)
    emit("tas.t1", ds.tas.isel(time=1).values)
    emit("rlat", ds.rlat.values)
    emit("rlon", ds.rlon.values)
    print("time", " ".join(str(t)[:19] for t in ds.time.values))


def cmip_tas(path, nt, ny, nx, sized_height):
    with netCDF4.Dataset(path, "w", format="NETCDF3_CLASSIC") as ds:
        ds.Conventions = "CF-1.4"
        ds.project_id = "CMIP5"
        ds.createDimension("time", None)
        ds.createDimension("lat", ny)
        ds.createDimension("lon", nx)
        ds.createDimension("bnds", 2)
        dims = ("time", "lat", "lon")
        if sized_height:
            ds.createDimension("height", 1)
            dims = ("time", "height", "lat", "lon")
        time = ds.createVariable("time", "f8", ("time",))
        time.units = "days since 1850-01-01"
        time.calendar = "noleap"
        time.axis = "T"
        time.standard_name = "time"
        time[:] = 15.5 + 365.0 / 12 * np.arange(nt)
        lat = ds.createVariable("lat", "f8", ("lat",))
        lat.units = "degrees_north"
        lat.axis = "Y"
        lat.standard_name = "latitude"
        lat[:] = np.linspace(-87.5, 87.5, ny)
        lon = ds.createVariable("lon", "f8", ("lon",))
        lon.units = "degrees_east"
        lon.axis = "X"
        lon.standard_name = "longitude"
        lon[:] = np.arange(nx) * 360.0 / nx
        height = ds.createVariable("height", "f8", ("height",) if sized_height else ())
        height.units = "m"
        height.axis = "Z"
        height.positive = "up"
        height.long_name = "height"
        height.standard_name = "height"
        height[:] = 2.0
        tas = ds.createVariable("tas", "f4", dims, fill_value=np.float32(1e20))
        tas.standard_name = "air_temperature"
        tas.units = "K"
        tas.cell_methods = "time: mean"
        if not sized_height:
            tas.coordinates = "height"
        data = field(nt, ny, nx, 2)
        tas[:] = data[:, None] if sized_height else data
    return xr.open_dataset(path)


def cmip(out):
    ds = cmip_tas(os.path.join(out, "tas_Amon_cmip.nc"), 4, 12, 16, False)
    emit("tas.t2", ds.tas.isel(time=2).values)
    print("time", " ".join(t.isoformat()[:19] for t in ds.time.values))
    ds = cmip_tas(os.path.join(out, "tas_height.nc"), 4, 12, 16, True)
    emit("tas_height.t2", ds.tas.isel(time=2, height=0).values)


def months(out):
    for name, calendar in (("months.nc", "360_day"), ("months_std.nc", "standard")):
        path = os.path.join(out, name)
        with netCDF4.Dataset(path, "w", format="NETCDF3_CLASSIC") as ds:
            ds.createDimension("time", 5)
            ds.createDimension("lat", 4)
            ds.createDimension("lon", 6)
            time = ds.createVariable("time", "f8", ("time",))
            time.units = "months since 1958-1-1"
            time.calendar = calendar
            time[:] = [0.0, 1.0, 2.0, 13.0, 25.5]
            lat = ds.createVariable("lat", "f4", ("lat",))
            lat.units = "degrees_north"
            lat[:] = [-30, -10, 10, 30]
            lon = ds.createVariable("lon", "f4", ("lon",))
            lon.units = "degrees_east"
            lon[:] = np.arange(6) * 60.0
            sst = ds.createVariable("sst", "f4", ("time", "lat", "lon"), fill_value=np.float32(-999))
            sst.units = "degC"
            sst[:] = field(5, 4, 6, 3) - 273.15
        try:
            ds = xr.open_dataset(path)
        except ValueError:
            # xarray refuses 'months since' outside 360_day unless asked not to decode times.
            ds = xr.open_dataset(path, decode_times=False)
        key = name[:-3]
        emit(f"{key}.sst.t3", ds.sst.isel(time=3).values)
        decoded = ds.time.values
        if np.issubdtype(decoded.dtype, np.number):
            print(f"{key}.time undecoded", " ".join(repr(float(v)) for v in decoded))
        else:
            print(f"{key}.time", " ".join(getattr(t, "isoformat", lambda: str(t))()[:19] for t in decoded))


def absolute(out):
    import datetime
    path = os.path.join(out, "absolute_time.nc")
    values = [20240115.0, 20240115.25, 20240229.5, 20240301.75]
    with netCDF4.Dataset(path, "w", format="NETCDF4") as ds:
        ds.createDimension("time", None)
        ds.createDimension("ncells", 5)
        ds.createDimension("lev", 1)
        time = ds.createVariable("time", "f8", ("time",))
        time.units = "day as %Y%m%d.%f"
        time.calendar = "proleptic_gregorian"
        time.axis = "T"
        time[:] = values
        v = ds.createVariable("ts", "f4", ("time", "ncells"))
        v.units = "K"
        v[:] = field(4, 1, 5, 9)[:, 0, :]
    dates = []
    for value in values:
        day = int(value)
        start = datetime.datetime(day // 10000, day // 100 % 100, day % 100)
        dates.append((start + datetime.timedelta(days=value - day)).isoformat()[:19])
    print("absolute.time", " ".join(dates))
    emit("absolute.ts.t2", xr.open_dataset(path, decode_times=False).ts.isel(time=2).values)


def nat(out):
    path = os.path.join(out, "all_missing_time.nc")
    with netCDF4.Dataset(path, "w", format="NETCDF4") as ds:
        ds.createDimension("time", 2)
        ds.createDimension("y", 3)
        ds.createDimension("x", 4)
        time = ds.createVariable("time", "f8", ("time",), fill_value=-9999.0)
        time.units = "hours since 2000-01-01"
        time[:] = np.ma.masked_all(2)
        v = ds.createVariable("precip", "f4", ("time", "y", "x"))
        v.units = "mm"
        v[:] = np.arange(24, dtype="f4").reshape(2, 3, 4) * 0.5
    ds = xr.open_dataset(path)
    emit("precip.t1", ds.precip.isel(time=1).values)


def longhdr(out):
    path = os.path.join(out, "long_header.nc")
    with netCDF4.Dataset(path, "w", format="NETCDF3_CLASSIC") as ds:
        ds.title = "A header longer than 64 KiB"
        ds.history = "; ".join(f"step {i}: regridded and averaged by an old tool" for i in range(2200))
        for i in range(40):
            setattr(ds, f"comment_{i:02}", "x" * (1000 + 37 * i))
        ds.createDimension("y", 5)
        ds.createDimension("x", 7)
        v = ds.createVariable("elevation", "i2", ("y", "x"))
        v.scale_factor = 0.5
        v.add_offset = 100.0
        v.units = "m"
        v.long_name = "x" * 70000
        v[:] = (np.arange(35).reshape(5, 7) * 3.0).astype("f4")
    ds = xr.open_dataset(path)
    print("header_bytes", os.path.getsize(path))
    emit("elevation", ds.elevation.values)


def h5cf(out):
    import h5py

    path = os.path.join(out, "cf.h5")
    with h5py.File(path, "w") as f:
        d = f.create_dataset("sst", data=np.array([[100, 200, -32768], [300, 32000, -5]], "i2"))
        d.attrs["_FillValue"] = np.int16(-32768)
        d.attrs["scale_factor"] = np.float32(0.01)
        d.attrs["add_offset"] = np.float32(20.0)
        d.attrs["valid_range"] = np.array([-1000, 31000], "i2")
        d.attrs["units"] = "degC"
    with netCDF4.Dataset(path) as nc:
        emit("netcdf4", np.ma.filled(nc["sst"][:].astype("f8"), np.nan))
    emit("xarray", xr.open_dataset(path, engine="netcdf4").sst.values)


def h5dims(out):
    import h5py

    path = os.path.join(out, "dims.h5")
    with h5py.File(path, "w") as f:
        scales = []
        for name, values, attrs in (
            ("time", [0.0, 31.0, 59.0], {"units": "days since 2000-01-01", "calendar": "noleap"}),
            ("lat", np.linspace(-30.0, 30.0, 4), {"units": "degrees_north"}),
            ("lon", np.arange(6) * 60.0, {"units": "degrees_east"}),
        ):
            d = f.create_dataset(name, data=np.asarray(values))
            d.attrs.update(attrs)
            d.make_scale(name)
            scales.append(d)
        data = field(3, 4, 6, 4)
        data[1, 0, 0] = -999.0
        t = f.create_dataset("t2m", data=data)
        t.attrs["units"] = "K"
        t.attrs["missing_value"] = np.float32(-999.0)
        for axis, scale in enumerate(scales):
            t.dims[axis].attach_scale(scale)
    ds = xr.open_dataset(path, engine="netcdf4")
    emit("t2m.t1", ds.t2m.isel(time=1).values)
    print("time", " ".join(t.isoformat()[:19] for t in ds.time.values))


def groups(out):
    path = os.path.join(out, "groups.nc")
    with netCDF4.Dataset(path, "w") as ds:
        ds.createDimension("time", 2)
        t = ds.createVariable("time", "f8", ("time",))
        t.units = "days since 2020-01-01"
        t[:] = [0.0, 1.0]
        product = ds.createGroup("PRODUCT")
        product.createDimension("y", 3)
        product.createDimension("x", 4)
        product.createVariable("ch4", "f4", ("time", "y", "x"))[:] = np.arange(24.0).reshape(2, 3, 4)
        product.createGroup("SUPPORT_DATA").createVariable("qa", "i1", ("time",))[:] = [1, 2]
    with netCDF4.Dataset(path) as ds:
        print("groups", " ".join(sorted(ds.groups)))


CASES = {"cordex": cordex, "cmip": cmip, "months": months, "absolute": absolute, "nat": nat, "longhdr": longhdr, "h5cf": h5cf, "h5dims": h5dims, "groups": groups}

if __name__ == "__main__":
    out_dir, case = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    CASES[case](out_dir)
