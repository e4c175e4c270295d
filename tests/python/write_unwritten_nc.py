#!/usr/bin/env python3
"""Write a NetCDF-4 file whose 1024^3 float variable is declared, chunked and never written: a file
of a few kilobytes whose variable reads as four gigabytes of fill values.

    python3 tests/python/write_unwritten_nc.py OUT.nc

Exit status 77 (skipped) when netCDF4 is not installed.
"""

import sys

try:
    import netCDF4
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install netCDF4)", file=sys.stderr)
    sys.exit(77)

with netCDF4.Dataset(sys.argv[1], "w", format="NETCDF4") as d:
    for name in ("z", "y", "x"):
        d.createDimension(name, 1024)
    d.createVariable("v", "f4", ("z", "y", "x"), chunksizes=(64, 64, 64))
