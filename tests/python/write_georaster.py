#!/usr/bin/env python3
"""Write georeferenced rasters as the reference tools write them and print, as text, what those
tools read back: the reference values of hdrvis's GeoTIFF and MintPy tests.

    python3 tests/python/write_georaster.py OUT_DIR CASE

CASE is one of:
  geotiff   rasterio (GDAL) GeoTIFFs in EPSG:4326: north.tif (float32, north up, deflate with
            the floating-point predictor, tiled, nodata -9999), south.tif (float64, south up:
            positive y pixel size, strips), point.tif (int16, AREA_OR_POINT=Point, LZW with the
            horizontal predictor), bands.tif (3 float32 bands, pixel interleaved), planar.tif
            (the same bands, band interleaved), utm.tif (EPSG:32654), rotated.tif (a rotated
            affine), plain.tif (no georeferencing), truncated.tif (north.tif cut short); values
            as rasterio reads them (nodata masked) and the pixel centres' longitudes and
            latitudes from rasterio's xy()
  mintpy    h5py files in MintPy's layout (root attributes as strings): velocity.h5 (geocoded,
            Y_STEP < 0), timeseries.h5 ((date, row, col) with its `date` list), radar.h5
            (radar coordinates, no X_FIRST), partial.h5 (X_FIRST without Y_FIRST and
            Y_STEP), truncated.h5 (velocity.h5 cut short); values by numpy and pixel centres by rasterio's xy()
            of MintPy's geotransform (X_FIRST, X_STEP, 0, Y_FIRST, 0, Y_STEP), as MintPy's
            save_gdal writes it
Each result is one line, `KEY VALUE VALUE ...`, arrays in C order with `nan` for masked values.
Exit status 77 (skipped) when a module is missing.
"""

import os
import sys

try:
    import numpy as np
    import h5py
    import rasterio
    from rasterio.crs import CRS
    from rasterio.transform import Affine, xy
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)


def emit(key, values):
    items = values if isinstance(values, (list, tuple)) else [values]
    print(key, *(repr(float(v)) if isinstance(v, (float, np.floating)) else str(v) for v in items))


def floats(a):
    a = np.ma.asarray(a, dtype=np.float64)
    return [float("nan") if m else float(v) for v, m in zip(a.ravel().data, np.ma.getmaskarray(a).ravel())]


def centres(transform, height, width):
    """Longitudes of the columns' and latitudes of the rows' pixel centres, by rasterio."""
    lon = [xy(transform, 0, c, offset="center")[0] for c in range(width)]
    lat = [xy(transform, r, 0, offset="center")[1] for r in range(height)]
    return lon, lat


def write_tif(path, data, transform, crs="EPSG:4326", tags=None, **kw):
    bands = data if data.ndim == 3 else data[None]
    profile = dict(driver="GTiff", height=bands.shape[1], width=bands.shape[2], count=bands.shape[0],
                   dtype=bands.dtype, transform=transform, **kw)
    if crs is not None:
        profile["crs"] = CRS.from_string(crs)
    with rasterio.open(path, "w", **profile) as d:
        if tags:
            d.update_tags(**tags)
        d.write(bands)


def report_tif(name, path, band=1):
    with rasterio.open(path) as d:
        a = d.read(band, masked=True)
        lon, lat = centres(d.transform, d.height, d.width)
        emit(f"{name}.shape", [d.height, d.width])
        emit(f"{name}.values", floats(a))
        emit(f"{name}.lon", lon)
        emit(f"{name}.lat", lat)
        emit(f"{name}.masked", int(np.ma.count_masked(a)))


def geotiff(out):
    rng = np.random.default_rng(7)
    h, w = 5, 7
    north = (rng.normal(size=(h, w)) * 100).astype(np.float32)
    north[1, 2] = -9999
    north[4, 6] = -9999
    t = Affine(0.25, 0, 139.0, 0, -0.5, 36.0)  # west edge 139, north edge 36
    write_tif(os.path.join(out, "north.tif"), north, t, nodata=-9999, compress="deflate", predictor=3,
              tiled=True, blockxsize=16, blockysize=16)
    report_tif("north", os.path.join(out, "north.tif"))

    south = rng.normal(size=(4, 6)) * 1e6
    t = Affine(0.5, 0, -10.0, 0, 0.25, -40.0)  # positive y size: row 0 is the southern edge
    write_tif(os.path.join(out, "south.tif"), south, t)
    report_tif("south", os.path.join(out, "south.tif"))

    point = rng.integers(-30000, 30000, size=(3, 4)).astype(np.int16)
    t = Affine(1.0, 0, 10.0, 0, -1.0, 50.0)
    write_tif(os.path.join(out, "point.tif"), point, t, compress="lzw", predictor=2, tags={"AREA_OR_POINT": "Point"})
    report_tif("point", os.path.join(out, "point.tif"))

    bands = (rng.normal(size=(3, 4, 5)) * 10).astype(np.float32)
    t = Affine(0.1, 0, 20.0, 0, -0.1, 10.0)
    write_tif(os.path.join(out, "bands.tif"), bands, t)
    write_tif(os.path.join(out, "planar.tif"), bands, t, interleave="band")
    report_tif("bands2", os.path.join(out, "bands.tif"), band=2)
    report_tif("planar3", os.path.join(out, "planar.tif"), band=3)

    # Packed: int16 with GDAL's scale, offset and unit (GDAL_METADATA), nodata in stored units.
    packed = rng.integers(-3000, 3000, size=(4, 5)).astype(np.int16)
    packed[2, 3] = -32768
    t = Affine(0.5, 0, 100.0, 0, -0.5, 10.0)
    with rasterio.open(os.path.join(out, "packed.tif"), "w", driver="GTiff", height=4, width=5,
                       count=1, dtype="int16", transform=t, crs=CRS.from_string("EPSG:4326"),
                       nodata=-32768) as d:
        d.scales = (0.01,)
        d.offsets = (-5.0,)
        d.units = ("m",)
        d.write(packed[None])
    with rasterio.open(os.path.join(out, "packed.tif")) as d:
        a = d.read(1, masked=True).astype(np.float64) * d.scales[0] + d.offsets[0]
        lon, lat = centres(d.transform, d.height, d.width)
        emit("packed.values", floats(a))
        emit("packed.lon", lon)
        emit("packed.lat", lat)
        emit("packed.masked", int(np.ma.count_masked(a)))
        emit("packed.scale", [d.scales[0], d.offsets[0]])
        print("packed.units", d.units[0])

    write_tif(os.path.join(out, "utm.tif"), north, Affine(30, 0, 500000, 0, -30, 4000000), crs="EPSG:32654")
    write_tif(os.path.join(out, "rotated.tif"), north, Affine(0.25, 0.1, 139.0, 0.1, -0.5, 36.0))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rasterio warns that the dataset is not georeferenced
        write_tif(os.path.join(out, "plain.tif"), north, Affine.identity(), crs=None)
    with open(os.path.join(out, "north.tif"), "rb") as f:
        whole = f.read()
    with open(os.path.join(out, "truncated.tif"), "wb") as f:
        f.write(whole[: len(whole) // 2])


MINTPY_ATTRS = {
    "X_FIRST": "130.5",
    "Y_FIRST": "33.2",
    "X_STEP": "0.01",
    "Y_STEP": "-0.005",
    "X_UNIT": "degrees",
    "Y_UNIT": "degrees",
    "WAVELENGTH": "0.05546576",
    "REF_LAT": "33.1875",
    "REF_LON": "130.525",
    "REF_Y": "2",
    "REF_X": "2",
    "PROCESSOR": "isce",
}


def write_h5(path, attrs, datasets):
    with h5py.File(path, "w") as f:
        for k, v in datasets.items():
            f.create_dataset(k, data=v)
        for k, v in attrs.items():
            f.attrs[k] = str(v)  # MintPy writes every attribute as a string


def mintpy(out):
    rng = np.random.default_rng(11)
    length, width = 6, 8
    a = dict(MINTPY_ATTRS, LENGTH=length, WIDTH=width)
    vel = (rng.normal(size=(length, width)) * 0.01).astype(np.float32)
    vel[3, 4] = np.nan
    write_h5(os.path.join(out, "velocity.h5"), dict(a, FILE_TYPE="velocity", UNIT="m/year"),
             {"velocity": vel, "velocityStd": np.abs(vel) / 10})
    gt = Affine(float(a["X_STEP"]), 0, float(a["X_FIRST"]), 0, float(a["Y_STEP"]), float(a["Y_FIRST"]))
    lon, lat = centres(gt, length, width)
    emit("velocity.values", floats(np.ma.masked_invalid(vel)))
    emit("velocity.lon", lon)
    emit("velocity.lat", lat)

    dates = ["20200101", "20200113", "20200125", "20200206", "20200218"]
    ts = (rng.normal(size=(len(dates), length, width)) * 0.02).astype(np.float32)
    write_h5(os.path.join(out, "timeseries.h5"), dict(a, FILE_TYPE="timeseries", UNIT="m"),
             {"timeseries": ts, "date": np.array(dates, dtype="S8"),
              "bperp": np.linspace(-50, 50, len(dates)).astype(np.float32)})
    emit("timeseries.dates", dates)
    emit("timeseries.index3", floats(ts[3]))
    # One colour range over the series, as numpy finds it (float32 values widened to float64).
    wide = ts.astype(np.float64)
    emit("timeseries.range", [wide.min(), wide.max()])
    emit("timeseries.robust13", list(np.percentile(wide[[1, 3]], [2, 98])))
    # The nearest acquisition to 2020-01-15, as numpy finds it.
    target = np.datetime64("2020-01-15")
    days = np.array([np.datetime64(f"{d[:4]}-{d[4:6]}-{d[6:]}") for d in dates])
    near = int(np.argmin(np.abs(days - target)))
    emit("timeseries.near", near)
    emit("timeseries.at", floats(ts[near]))

    radar = rng.normal(size=(length, width)).astype(np.float32)
    ra = {k: v for k, v in a.items() if not k.startswith(("X_", "Y_"))}
    write_h5(os.path.join(out, "radar.h5"), dict(ra, FILE_TYPE="velocity", UNIT="m/year"), {"velocity": radar})
    emit("radar.values", floats(radar))

    partial = {k: v for k, v in a.items() if k not in ("Y_FIRST", "Y_STEP")}
    write_h5(os.path.join(out, "partial.h5"), dict(partial, FILE_TYPE="velocity"), {"velocity": vel})
    with open(os.path.join(out, "velocity.h5"), "rb") as f:
        whole = f.read()
    with open(os.path.join(out, "truncated.h5"), "wb") as f:
        f.write(whole[: len(whole) // 3])


def main():
    out, case = sys.argv[1], sys.argv[2]
    {"geotiff": geotiff, "mintpy": mintpy}[case](out)


if __name__ == "__main__":
    main()
