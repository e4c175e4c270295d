#!/usr/bin/env python3
"""Write the fuzz corpus's seed files, one small valid file per reader, with each format's tool.

    python3 tests/python/write_fuzz_seeds.py tests/fuzz/seeds

The seeds are kept in the repository (tests/fuzz/seeds/, a few kilobytes each), so the fuzz test
(tests/integration/fuzz_corpus.rs) needs no Python; run this to make them again. Every seed holds
the same 5x4x3 float32 volume (x fastest), values 0.5 * i - 3 j + 10 k:

  seed.npy           numpy
  seed.npz           numpy savez_compressed (deflated members v and w)
  seed.nrrd          pynrrd, attached header, gzip encoding
  seed_classic.nc    netCDF4, NETCDF3_CLASSIC, variable v with units and _FillValue
  seed_nc4.nc        netCDF4, NETCDF4, v chunked, zlib + shuffle
  seed.h5            h5py: /v chunked, gzip + shuffle, a units attribute; /g/w contiguous int16
  seed.vti           VTK XML ImageData, zlib-compressed appended data
  seed.vtk           VTK legacy STRUCTURED_POINTS, binary
  seed.exr           OpenEXR, R, G, B, ZIP compression, 6x4
  seed.tif           rasterio (GDAL) GeoTIFF, EPSG:4326, deflate, 6x4, nodata -9999
  seed.grib1         ecCodes GRIB1, simple packing with a bitmap, 13x7 (write_grib_cases.py)
  seed_bitmap.grib2  ecCodes GRIB2, simple packing with a bitmap, 13x7
  seed_jpeg.grib2    ecCodes GRIB2, JPEG 2000 packing, 25x13
  seed_complex.grib2 ecCodes GRIB2, complex packing with spatial differencing, 25x13

Exit status 77 (skipped) when one of the modules is missing.
"""

import os
import sys

try:
    import h5py
    import netCDF4
    import nrrd
    import numpy as np
    import OpenEXR
    import rasterio
    import vtk
    from rasterio.transform import from_origin
    from vtk.util.numpy_support import numpy_to_vtk
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)


def volume():
    k, j, i = np.meshgrid(np.arange(3), np.arange(4), np.arange(5), indexing="ij")
    return (0.5 * i - 3.0 * j + 10.0 * k).astype("f4")


def vtk_image(data):
    image = vtk.vtkImageData()
    image.SetDimensions(data.shape[2], data.shape[1], data.shape[0])
    array = numpy_to_vtk(data.ravel(), deep=True)
    array.SetName("v")
    image.GetPointData().SetScalars(array)
    return image


def main():
    out = sys.argv[1]
    path = lambda name: os.path.join(out, name)
    v = volume()
    np.save(path("seed.npy"), v)
    np.savez_compressed(path("seed.npz"), v=v, w=v[0].astype("i2"))
    nrrd.write(path("seed.nrrd"), v, {"encoding": "gzip"}, index_order="C")
    for name, fmt in (("seed_classic.nc", "NETCDF3_CLASSIC"), ("seed_nc4.nc", "NETCDF4")):
        with netCDF4.Dataset(path(name), "w", format=fmt) as d:
            for dim, n in zip("zyx", v.shape):
                d.createDimension(dim, n)
            d.createVariable("x", "f4", ("x",))[:] = np.arange(5, dtype="f4")
            var = d.createVariable("v", "f4", ("z", "y", "x"), fill_value=-999.0,
                                   zlib=fmt == "NETCDF4", shuffle=fmt == "NETCDF4",
                                   chunksizes=(1, 4, 5) if fmt == "NETCDF4" else None)
            var.units = "K"
            var[:] = v
    with h5py.File(path("seed.h5"), "w") as f:
        d = f.create_dataset("v", data=v, chunks=(1, 2, 5), compression="gzip", shuffle=True)
        d.attrs["units"] = "m"
        f.create_group("g")["w"] = v.astype("i2")
    xml = vtk.vtkXMLImageDataWriter()
    xml.SetFileName(path("seed.vti"))
    xml.SetInputData(vtk_image(v))
    xml.SetDataModeToAppended()
    xml.SetCompressorTypeToZLib()
    xml.Write()
    legacy = vtk.vtkStructuredPointsWriter()
    legacy.SetFileName(path("seed.vtk"))
    legacy.SetInputData(vtk_image(v))
    legacy.SetFileTypeToBinary()
    legacy.Write()
    picture = np.linspace(0.0, 8.0, 24, dtype="f4").reshape(4, 6)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION},
                 {"R": picture, "G": picture + 1, "B": picture[::-1].copy()}).write(
        path("seed.exr"))
    grid = picture * 10
    grid[0, 0] = -9999.0
    profile = dict(driver="GTiff", width=6, height=4, count=1, dtype="float32", crs="EPSG:4326",
                   transform=from_origin(10.0, 50.0, 0.5, 0.5), nodata=-9999.0,
                   compress="deflate")
    with rasterio.open(path("seed.tif"), "w", **profile) as d:
        d.write(grid, 1)
    grib_seeds(out)


def grib_seeds(out):
    """GRIB seeds: files of tests/python/write_grib_cases.py (ecCodes) copied under seed names."""
    import shutil
    import subprocess
    import tempfile
    here = os.path.dirname(os.path.abspath(__file__))
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, os.path.join(here, "write_grib_cases.py"), tmp], check=True,
                       stdout=subprocess.DEVNULL)
        for source, seed in (("grib1_regular_ll.grib1", "seed.grib1"),
                             ("grid_simple_bitmap.grib2", "seed_bitmap.grib2"),
                             ("grid_jpeg.grib2", "seed_jpeg.grib2"),
                             ("grid_complex_spatial_differencing.grib2", "seed_complex.grib2")):
            shutil.copyfile(os.path.join(tmp, source), os.path.join(out, seed))


if __name__ == "__main__":
    main()
