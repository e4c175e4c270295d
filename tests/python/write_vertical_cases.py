#!/usr/bin/env python3
"""Write model-level NetCDF files as atmosphere and ocean models write them (netCDF4-python) and
print the fields at a pressure or depth computed independently with numpy: the reference of
hdrvis's parametric vertical coordinate tests.

    python3 tests/python/write_vertical_cases.py OUT_DIR

Files:
  hybrid_cf.nc    CAM-like T(time, lev, lat, lon) on atmosphere_hybrid_sigma_pressure_coordinate
                  with formula_terms "a: hyam b: hybm p0: P0 ps: PS"
  hybrid_ncar.nc  the same field with NCAR's older lev attributes A_var, B_var, PS_var and no P0
                  (p0 is then 1000 hPa)
  ocean_s.nc      ROMS-like temp(time, s_rho, eta_rho, xi_rho) on ocean_s_coordinate_g2 with
                  formula_terms "s: s_rho C: Cs_r eta: zeta depth: h depth_c: hc"
Printed, one `KEY VALUE ...` line each, C order, `nan` where the level is outside the column:
  hybrid.p500      T at 500 hPa, time 1: linear in ln p between the bracketing model levels of
                   each column, the rule of NCL's vinth2p (intyp=2), without extrapolation
  hybrid.p1000     T at 1000 hPa, time 1 (below the surface where PS < 1000 hPa: missing)
  hybrid_ncar.p850 T at 850 hPa, time 0, with p0 = 100000 Pa
  ocean.d100       temp at 100 m depth (z = -100), time 0: linear in z, CF's g2 formula
Exit status 77 (skipped) when a module is missing.
"""

import os
import sys

try:
    import netCDF4
    import numpy as np
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)


def emit(key, values):
    flat = np.asarray(values, dtype=float).ravel()
    print(key, " ".join("nan" if np.isnan(v) else repr(float(v)) for v in flat))


def column_interp(x_levels, values, target):
    """Linear interpolation of `values` at `target` along axis 0, in the coordinate `x_levels`
    (same shape), leaving columns that do not bracket the target as NaN."""
    out = np.full(values.shape[1:], np.nan)
    for idx in np.ndindex(values.shape[1:]):
        x = x_levels[(slice(None),) + idx]
        v = values[(slice(None),) + idx]
        for k in range(len(x) - 1):
            lo, hi = min(x[k], x[k + 1]), max(x[k], x[k + 1])
            if lo <= target <= hi:
                w = 0.0 if x[k + 1] == x[k] else (target - x[k]) / (x[k + 1] - x[k])
                out[idx] = v[k] + w * (v[k + 1] - v[k])
                break
    return out


def hybrid_field():
    nt, nlev, nlat, nlon = 2, 8, 5, 6
    # CAM-like coefficients, top to bottom: pure pressure aloft, terrain-following below.
    hyam = np.array([0.0030, 0.0100, 0.0500, 0.1500, 0.2000, 0.1500, 0.0500, 0.0000])
    hybm = np.array([0.0000, 0.0000, 0.0000, 0.0500, 0.2500, 0.5000, 0.8000, 0.9850])
    lat = np.linspace(-60, 60, nlat)
    lon = np.arange(nlon) * 60.0
    t, la, lo = np.meshgrid(np.arange(nt), lat, lon, indexing="ij")
    # Surface pressure from 960 to 1040 hPa: some columns do not reach 1000 hPa.
    ps = 100000.0 + 4000.0 * np.sin(np.radians(la) * 2 + t) * np.cos(np.radians(lo))
    p = hyam[None, :, None, None] * 100000.0 + hybm[None, :, None, None] * ps[:, None]
    temp = 288.0 * (p / 100000.0) ** 0.19 + np.cos(np.radians(la))[:, None] * 3.0
    return hyam, hybm, lat, lon, ps, p, temp


def write_hybrid(path, ncar):
    hyam, hybm, lat, lon, ps, p, temp = hybrid_field()
    nt, nlev = temp.shape[:2]
    with netCDF4.Dataset(path, "w", format="NETCDF4_CLASSIC") as ds:
        for name, n in (("time", nt), ("lev", nlev), ("lat", len(lat)), ("lon", len(lon))):
            ds.createDimension(name, n)
        tv = ds.createVariable("time", "f8", ("time",))
        tv.units = "days since 2000-01-01"
        tv[:] = np.arange(nt)
        lev = ds.createVariable("lev", "f8", ("lev",))
        lev.long_name = "hybrid level at midpoints (1000*(A+B))"
        lev.units = "hPa"
        lev.positive = "down"
        lev[:] = 1000.0 * (hyam + hybm)
        if ncar:
            lev.A_var = "hyam"
            lev.B_var = "hybm"
            lev.PS_var = "PS"
        else:
            lev.standard_name = "atmosphere_hybrid_sigma_pressure_coordinate"
            lev.formula_terms = "a: hyam b: hybm p0: P0 ps: PS"
            p0 = ds.createVariable("P0", "f8", ())
            p0.units = "Pa"
            p0[...] = 100000.0
        for name, values in (("hyam", hyam), ("hybm", hybm)):
            v = ds.createVariable(name, "f8", ("lev",))
            v[:] = values
        la = ds.createVariable("lat", "f8", ("lat",))
        la.units = "degrees_north"
        la[:] = lat
        lo = ds.createVariable("lon", "f8", ("lon",))
        lo.units = "degrees_east"
        lo[:] = lon
        psv = ds.createVariable("PS", "f4", ("time", "lat", "lon"))
        psv.units = "Pa"
        psv[:] = ps
        tv = ds.createVariable("T", "f4", ("time", "lev", "lat", "lon"))
        tv.units = "K"
        tv[:] = temp
    # The reference reads back what was stored (PS and T as float32).
    with netCDF4.Dataset(path) as ds:
        ps = ds["PS"][:].astype(float)
        temp = ds["T"][:].astype(float)
    p = hyam[None, :, None, None] * 100000.0 + hybm[None, :, None, None] * ps[:, None]
    return p, temp


def write_ocean(path):
    nt, ns, ny, nx = 1, 10, 4, 5
    s_rho = (np.arange(ns) - ns + 0.5) / ns
    theta_s, theta_b = 5.0, 0.4
    cs = (1 - theta_b) * np.sinh(theta_s * s_rho) / np.sinh(theta_s) + theta_b * (
        np.tanh(theta_s * (s_rho + 0.5)) / (2 * np.tanh(0.5 * theta_s)) - 0.5)
    hc = 20.0
    y, x = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    h = 50.0 + 60.0 * x + 10.0 * y
    zeta = 0.3 * np.sin(x + y)[None]
    s_big = (hc * s_rho[:, None, None] + h[None] * cs[:, None, None]) / (hc + h[None])
    z = zeta[:, None] + (zeta[:, None] + h[None, None]) * s_big[None]
    temp = 4.0 + 16.0 * np.exp(z / 150.0)
    with netCDF4.Dataset(path, "w", format="NETCDF4_CLASSIC") as ds:
        for name, n in (("ocean_time", nt), ("s_rho", ns), ("eta_rho", ny), ("xi_rho", nx)):
            ds.createDimension(name, n)
        t = ds.createVariable("ocean_time", "f8", ("ocean_time",))
        t.units = "seconds since 2001-01-01"
        t[:] = [0.0]
        s = ds.createVariable("s_rho", "f8", ("s_rho",))
        s.standard_name = "ocean_s_coordinate_g2"
        s.formula_terms = "s: s_rho C: Cs_r eta: zeta depth: h depth_c: hc"
        s.positive = "up"
        s[:] = s_rho
        c = ds.createVariable("Cs_r", "f8", ("s_rho",))
        c[:] = cs
        hv = ds.createVariable("h", "f8", ("eta_rho", "xi_rho"))
        hv.units = "m"
        hv[:] = h
        hcv = ds.createVariable("hc", "f8", ())
        hcv.units = "m"
        hcv[...] = hc
        zv = ds.createVariable("zeta", "f8", ("ocean_time", "eta_rho", "xi_rho"))
        zv.units = "m"
        zv[:] = zeta
        tv = ds.createVariable("temp", "f8", ("ocean_time", "s_rho", "eta_rho", "xi_rho"))
        tv.units = "Celsius"
        tv[:] = temp
    return z, temp


def main(out):
    p, temp = write_hybrid(os.path.join(out, "hybrid_cf.nc"), ncar=False)
    emit("hybrid.p500", column_interp(np.log(p[1]), temp[1], np.log(50000.0)))
    emit("hybrid.p1000", column_interp(np.log(p[1]), temp[1], np.log(100000.0)))
    p, temp = write_hybrid(os.path.join(out, "hybrid_ncar.nc"), ncar=True)
    emit("hybrid_ncar.p850", column_interp(np.log(p[0]), temp[0], np.log(85000.0)))
    z, temp = write_ocean(os.path.join(out, "ocean_s.nc"))
    emit("ocean.d100", column_interp(z[0], temp[0], -100.0))
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
