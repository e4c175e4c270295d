"""Map projections and uneven axes as PROJ and netCDF4-python give them, for
tests/integration/projections.rs.

  projection_cases.py points REQUEST.json   PROJ (pyproj) on a table of points: REQUEST is a
      list of {"proj": PROJ string, "forward": [[lon, lat], ...], "inverse": [[x, y], ...]};
      prints per entry {"forward": [[x, y] | null], "inverse": [[lon, lat] | null]} as JSON
      (null where PROJ places no point).
  projection_cases.py write DIR   writes, with netCDF4-python, a Gaussian-latitude grid
      (gaussian.nc: N48, 96 latitudes at the Gauss-Legendre nodes, 192 longitudes) and an
      ocean grid refined at the equator (ocean.nc: 1/4 deg within 10 deg of it, 2 deg near the
      poles, 1 deg longitudes); each holds t = the node's latitude and u = its longitude. Also
      a 5 deg world grid of winds (wind.nc: uas = 10 cos(lat), vas = 2 sin(lon), m s-1) and of
      sea-level pressure (psl.nc: 1000 + 10 sin(2 lat) cos(lon), hPa), with CF long_names.

Exit 77 when pyproj, numpy or netCDF4 is missing."""

import json
import math
import sys

try:
    import numpy as np
    import netCDF4
    from pyproj import Transformer
except ImportError as e:  # pragma: no cover - reported to the test as skipped
    print(e, file=sys.stderr)
    sys.exit(77)

SPHERE = "+proj=latlong +R=6371008.8 +no_defs"


def finite(pair):
    return [float(v) for v in pair] if all(math.isfinite(v) for v in pair) else None


def points(request_path):
    with open(request_path) as f:
        request = json.load(f)
    out = []
    for entry in request:
        fwd = Transformer.from_crs(SPHERE, entry["proj"], always_xy=True)
        inv = Transformer.from_crs(entry["proj"], SPHERE, always_xy=True)
        result = {"forward": [], "inverse": []}
        for lon, lat in entry.get("forward", []):
            x, y = fwd.transform(lon, lat, errcheck=False)
            result["forward"].append(finite((x, y)))
        for x, y in entry.get("inverse", []):
            lon, lat = inv.transform(x, y, errcheck=False)
            result["inverse"].append(finite((lon, lat)))
        out.append(result)
    json.dump(out, sys.stdout)


def write_grid(path, lats, lons, fields=None, lat_edges=None):
    """A (lat, lon) grid; with `lat_edges` (the outer edges of the end cells) CF cell bounds on
    latitude as models write them: midpoints between nodes, the given outer edges."""
    d = netCDF4.Dataset(path, "w")
    d.createDimension("lat", len(lats))
    d.createDimension("lon", len(lons))
    lat = d.createVariable("lat", "f8", ("lat",))
    lat.units = "degrees_north"
    lat[:] = lats
    if lat_edges is not None:
        d.createDimension("nv", 2)
        lat.bounds = "lat_bnds"
        mids = 0.5 * (np.asarray(lats[1:]) + np.asarray(lats[:-1]))
        edges = np.concatenate([[lat_edges[0]], mids, [lat_edges[1]]])
        d.createVariable("lat_bnds", "f8", ("lat", "nv"))[:] = np.stack([edges[:-1], edges[1:]], 1)
    lon = d.createVariable("lon", "f8", ("lon",))
    lon.units = "degrees_east"
    lon[:] = lons
    grid_lon, grid_lat = np.meshgrid(lons, lats)
    if fields is None:
        fields = [("t", "degrees", None, grid_lat), ("u", "degrees", None, grid_lon)]
    else:
        fields = [(name, units, long, f(grid_lon, grid_lat)) for name, units, long, f in fields]
    for name, units, long_name, values in fields:
        v = d.createVariable(name, "f8", ("lat", "lon"))
        v.units = units
        if long_name:
            v.long_name = long_name
        v[:] = values
    d.close()


def write(directory):
    nodes, _ = np.polynomial.legendre.leggauss(96)
    gaussian = np.degrees(np.arcsin(nodes))
    write_grid(f"{directory}/gaussian.nc", gaussian, np.arange(192) * 1.875 - 180.0)
    ocean = np.concatenate(
        [
            np.arange(-79.0, -20.0, 2.0),
            np.arange(-20.0, -10.0, 1.0),
            np.arange(-10.0, 10.0, 0.25),
            np.arange(10.0, 20.0, 1.0),
            np.arange(20.0, 80.0, 2.0),
        ]
    )
    # Its end cells reach 80°S (half a spacing) and 80°N (a whole one) as its bounds say.
    write_grid(f"{directory}/ocean.nc", ocean, np.arange(0.5, 360.0, 1.0), lat_edges=(-80.0, 80.0))
    lats, lons = np.arange(-87.5, 90.0, 5.0), np.arange(-177.5, 180.0, 5.0)
    rad = np.radians
    write_grid(
        f"{directory}/wind.nc",
        lats,
        lons,
        [
            ("uas", "m s-1", "eastward wind", lambda lo, la: 10.0 * np.cos(rad(la))),
            ("vas", "m s-1", "northward wind", lambda lo, la: 2.0 * np.sin(rad(lo))),
        ],
    )
    write_grid(
        f"{directory}/psl.nc",
        lats,
        lons,
        [
            (
                "psl",
                "hPa",
                "sea-level pressure",
                lambda lo, la: 1000.0 + 10.0 * np.sin(rad(2.0 * la)) * np.cos(rad(lo)),
            )
        ],
    )
    print(json.dumps({"gaussian": gaussian.tolist(), "ocean": ocean.tolist()}))


if __name__ == "__main__":
    {"points": points, "write": write}[sys.argv[1]](sys.argv[2])
