#!/usr/bin/env python3
"""Check a NetCDF file written by hdrvis with the reference readers (netCDF4-python and xarray).

    python3 tests/python/check_netcdf.py FILE.nc --var NAME --expect EXPECTED.npy
        [--units UNITS] [--long-name TEXT] [--coord DIM=EXPECTED.npy ...]
        [--aux NAME:DIM=EXPECTED.npy ...] [--rtol R] [--atol A]

Both readers must decode the variable (CF masking and unpacking on) to the values in EXPECTED.npy,
which has the variable's shape (C order) and marks missing cells as NaN; NaNs must sit in the same
places. The file must declare Conventions CF-*, the variable its units/long_name when given, and
every dimension of the variable a strictly monotonic coordinate variable, compared with the given
.npy when --coord names it. --aux names a 1-D auxiliary coordinate on dimension DIM (listed in the
variable's `coordinates` attribute): xarray must read it as a coordinate on DIM with the values given.

Exit status: 0 when every check passes, 1 with one line per failure on stderr, 2 on bad arguments,
77 (the automake "skipped" code) when numpy, netCDF4 or xarray is not installed, so a Rust test can
report a skip instead of a failure.
"""

import argparse
import sys

try:
    import numpy as np
    import netCDF4
    import xarray as xr
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install numpy netCDF4 xarray)", file=sys.stderr)
    sys.exit(77)


def compare(label, got, want, rtol, atol, failures):
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    if got.shape != want.shape:
        failures.append(f"{label}: shape {got.shape}, expected {want.shape}")
        return
    if not np.array_equal(np.isnan(got), np.isnan(want)):
        failures.append(f"{label}: NaN at {int(np.isnan(got).sum())} cells, expected "
                        f"{int(np.isnan(want).sum())} (positions differ)")
        return
    ok = np.isclose(got, want, rtol=rtol, atol=atol, equal_nan=True)
    if not ok.all():
        idx = tuple(int(i) for i in np.argwhere(~ok)[0])
        failures.append(f"{label}: {int((~ok).sum())} values differ, first at {idx}: "
                        f"{got[idx]!r} vs expected {want[idx]!r}")


def monotonic(values):
    d = np.diff(np.asarray(values, dtype=np.float64))
    return bool(np.all(d > 0) or np.all(d < 0))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("file")
    parser.add_argument("--var", required=True)
    parser.add_argument("--expect", required=True, help=".npy with the expected decoded values")
    parser.add_argument("--units")
    parser.add_argument("--long-name")
    parser.add_argument("--coord", action="append", default=[], metavar="DIM=EXPECTED.npy")
    parser.add_argument("--aux", action="append", default=[], metavar="NAME:DIM=EXPECTED.npy")
    parser.add_argument("--coord-attr", action="append", default=[], metavar="DIM:KEY=VALUE",
                        help="an attribute xarray must read on a coordinate")
    parser.add_argument("--rtol", type=float, default=1e-6)
    parser.add_argument("--atol", type=float, default=0.0)
    args = parser.parse_args()

    expected = np.load(args.expect)
    coord_expect = {}
    for item in args.coord:
        dim, sep, npy = item.partition("=")
        if not sep:
            parser.error(f"--coord {item!r} is not DIM=EXPECTED.npy")
        coord_expect[dim] = np.load(npy)
    aux_expect = {}
    for item in args.aux:
        head, sep, npy = item.partition("=")
        name, colon, dim = head.partition(":")
        if not (sep and colon):
            parser.error(f"--aux {item!r} is not NAME:DIM=EXPECTED.npy")
        aux_expect[name] = (dim, np.load(npy))
    failures = []

    with netCDF4.Dataset(args.file) as ds:
        conventions = getattr(ds, "Conventions", "")
        if not str(conventions).startswith("CF-"):
            failures.append(f"Conventions is {conventions!r}, expected CF-*")
        if args.var not in ds.variables:
            failures.append(f"netCDF4: no variable {args.var!r}; has {sorted(ds.variables)}")
        else:
            var = ds.variables[args.var]
            compare(f"netCDF4 {args.var}", np.ma.filled(var[:].astype(np.float64), np.nan),
                    expected, args.rtol, args.atol, failures)
            for key, want in (("units", args.units), ("long_name", args.long_name)):
                if want is not None and getattr(var, key, None) != want:
                    failures.append(f"{args.var}.{key} is {getattr(var, key, None)!r}, expected {want!r}")
            for dim in var.dimensions:
                if dim not in ds.variables:
                    failures.append(f"dimension {dim!r} has no coordinate variable")
                    continue
                values = np.ma.filled(ds.variables[dim][:].astype(np.float64), np.nan)
                if not monotonic(values):
                    failures.append(f"coordinate {dim!r} is not strictly monotonic")
                if dim in coord_expect:
                    compare(f"netCDF4 coordinate {dim}", values, coord_expect[dim],
                            args.rtol, args.atol, failures)

    with xr.open_dataset(args.file, decode_cf=True, mask_and_scale=True) as ds:
        if args.var not in ds:
            failures.append(f"xarray: no data variable {args.var!r}; has {sorted(ds.data_vars)}")
        else:
            compare(f"xarray {args.var}", ds[args.var].values, expected, args.rtol, args.atol,
                    failures)
            for dim, want in coord_expect.items():
                if dim in ds.coords:
                    compare(f"xarray coordinate {dim}", ds.coords[dim].values, want, args.rtol,
                            args.atol, failures)
                else:
                    failures.append(f"xarray: {dim!r} is not a coordinate")
            for item in args.coord_attr:
                head, _, want = item.partition("=")
                dim, _, key = head.partition(":")
                got = ds.coords[dim].attrs.get(key) if dim in ds.coords else None
                if got != want:
                    failures.append(f"xarray: {dim}.{key} is {got!r}, expected {want!r}")
            for name, (dim, want) in aux_expect.items():
                if name not in ds[args.var].coords:
                    failures.append(f"xarray: {name!r} is not a coordinate of {args.var!r}")
                    continue
                if ds.coords[name].dims != (dim,):
                    failures.append(f"xarray: {name!r} lies on {ds.coords[name].dims}, expected ({dim!r},)")
                compare(f"xarray coordinate {name}", ds.coords[name].values, want, args.rtol,
                        args.atol, failures)

    for failure in failures:
        print(f"{args.file}: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
