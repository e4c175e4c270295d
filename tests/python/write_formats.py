#!/usr/bin/env python3
"""Write one small volume in every volume format hdrvis reads, through each format's reference tool.

    python3 tests/python/write_formats.py OUT_DIR

The volume has nx=5, ny=4, nz=3 cells, values v(i, j, k) = (1 + i + 10 j + 100 k) * 10**(k - 1)
* (-1)**i as float32 (four decades, both signs), spacing (0.5, 0.25, 2), minimum corner
(-1, 2, 0.5). OUT_DIR gets:

  expect.npy                      the values, shape (nz, ny, nx), C order (x fastest)
  counts.npy                      int16 (i + 10 j + 100 k), the integer HDF5 dataset's values
  vti_<layout>.vti                vtkXMLImageDataWriter, CellData: zlib (VTK's default: appended
                                  base64), zlib_binary, zlib_raw, zlib_uint32, zlib_blocks (many
                                  64-byte blocks), lz4, lzma, ascii, raw (appended, uncompressed)
  vti_points.vti                  PointData on the cell centres (origin moved by half a cell)
  vtk_points_{binary,ascii}.vtk   vtkStructuredPointsWriter, POINT_DATA on the cell centres
  vtk_cells_{binary,ascii}.vtk    vtkStructuredPointsWriter, CELL_DATA on a grid of n + 1 points
  rect_uniform_{binary,ascii}.vtk vtkRectilinearGridWriter, point data on the centres
  rect_stretched_binary.vtk       vtkRectilinearGridWriter, z centres 1, 2, 4 (non-uniform)
  nrrd_<encoding>.nrrd / .nhdr    pynrrd, encodings raw, gzip, bzip2, ascii; attached and detached
  volume.h5                       h5py: /fields/density (f32, chunked + gzip + shuffle),
                                  /fields/density_f64 (contiguous), /counts (int16), /map (2-D)
  npz_stored.npz, npz_deflated.npz np.savez and np.savez_compressed: density, counts, map and
                                  x (the x centres), the same arrays as volume.h5
  npz_bzip2.npz                   density.npy in a bzip2 zip member (zipfile), which numpy never
                                  writes: hdrvis refuses it

Exit status 77 (skipped) when numpy, vtk, pynrrd or h5py is not installed.
"""

import io
import os
import sys
import zipfile

try:
    import numpy as np
    import vtk
    from vtk.util import numpy_support
    import nrrd
    import h5py
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install numpy vtk pynrrd h5py)", file=sys.stderr)
    sys.exit(77)

NX, NY, NZ = 5, 4, 3
SPACING = (0.5, 0.25, 2.0)
CORNER = (-1.0, 2.0, 0.5)
CENTRE0 = tuple(c + 0.5 * s for c, s in zip(CORNER, SPACING))


def values():
    k, j, i = np.meshgrid(np.arange(NZ), np.arange(NY), np.arange(NX), indexing="ij")
    v = (1.0 + i + 10.0 * j + 100.0 * k) * 10.0 ** (k - 1.0) * (-1.0) ** i
    return v.astype(np.float32)


def vtk_array(data, name):
    arr = numpy_support.numpy_to_vtk(np.ascontiguousarray(data).ravel(), deep=True)
    arr.SetName(name)
    return arr


def image(data, on_points):
    img = vtk.vtkImageData()
    if on_points:
        img.SetDimensions(NX, NY, NZ)
        img.SetOrigin(*CENTRE0)
        img.SetSpacing(*SPACING)
        img.GetPointData().SetScalars(vtk_array(data, "density"))
    else:
        img.SetDimensions(NX + 1, NY + 1, NZ + 1)
        img.SetOrigin(*CORNER)
        img.SetSpacing(*SPACING)
        img.GetCellData().SetScalars(vtk_array(data, "density"))
    return img


def write_vti(out, data):
    layouts = {
        "zlib": lambda w: None,
        "zlib_binary": lambda w: w.SetDataModeToBinary(),
        "zlib_raw": lambda w: w.EncodeAppendedDataOff(),
        "zlib_uint32": lambda w: w.SetHeaderTypeToUInt32(),
        "zlib_blocks": lambda w: w.SetBlockSize(64),
        "lz4": lambda w: w.SetCompressorTypeToLZ4(),
        "lzma": lambda w: w.SetCompressorTypeToLZMA(),
        "ascii": lambda w: w.SetDataModeToAscii(),
        "raw": lambda w: (w.SetCompressorTypeToNone(), w.EncodeAppendedDataOff()),
    }
    for name, configure in layouts.items():
        w = vtk.vtkXMLImageDataWriter()
        w.SetInputData(image(data, on_points=False))
        configure(w)
        w.SetFileName(os.path.join(out, f"vti_{name}.vti"))
        assert w.Write() == 1, name
    w = vtk.vtkXMLImageDataWriter()
    w.SetInputData(image(data, on_points=True))
    w.SetFileName(os.path.join(out, "vti_points.vti"))
    assert w.Write() == 1


def write_legacy(out, data):
    for kind in ("binary", "ascii"):
        for on_points, tag in ((True, "points"), (False, "cells")):
            w = vtk.vtkStructuredPointsWriter()
            w.SetInputData(image(data, on_points))
            getattr(w, f"SetFileTypeTo{kind.capitalize() if kind == 'binary' else 'ASCII'}")()
            w.SetFileName(os.path.join(out, f"vtk_{tag}_{kind}.vtk"))
            assert w.Write() == 1
        uniform = [CENTRE0[a] + SPACING[a] * np.arange(n) for a, n in enumerate((NX, NY, NZ))]
        write_rectilinear(os.path.join(out, f"rect_uniform_{kind}.vtk"), data, uniform, kind)
    stretched = [uniform[0], uniform[1], np.array([1.0, 2.0, 4.0])]
    write_rectilinear(os.path.join(out, "rect_stretched_binary.vtk"), data, stretched, "binary")


def write_rectilinear(path, data, coords, kind):
    grid = vtk.vtkRectilinearGrid()
    grid.SetDimensions(NX, NY, NZ)
    grid.SetXCoordinates(vtk_array(coords[0], "x"))
    grid.SetYCoordinates(vtk_array(coords[1], "y"))
    grid.SetZCoordinates(vtk_array(coords[2], "z"))
    grid.GetPointData().SetScalars(vtk_array(data, "density"))
    w = vtk.vtkRectilinearGridWriter()
    w.SetInputData(grid)
    getattr(w, f"SetFileTypeTo{kind.capitalize() if kind == 'binary' else 'ASCII'}")()
    w.SetFileName(path)
    assert w.Write() == 1


def write_nrrd(out, data):
    header = {
        "space": "right-anterior-superior",
        "space directions": np.diag(SPACING),
        "space origin": np.array(CENTRE0),
    }
    for encoding in ("raw", "gzip", "bzip2", "ascii"):
        for detached, ext in ((False, "nrrd"), (True, "nhdr")):
            path = os.path.join(out, f"nrrd_{encoding}.{ext}")
            nrrd.write(path, data, dict(header, encoding=encoding), detached_header=detached,
                       index_order="C")


def count_values():
    k, j, i = np.meshgrid(np.arange(NZ), np.arange(NY), np.arange(NX), indexing="ij")
    return (i + 10 * j + 100 * k).astype(np.int16)


def write_hdf5(out, data):
    counts = count_values()
    np.save(os.path.join(out, "counts.npy"), counts)
    with h5py.File(os.path.join(out, "volume.h5"), "w") as f:
        fields = f.create_group("fields")
        d = fields.create_dataset("density", data=data, chunks=(1, 2, 3), compression="gzip",
                                  shuffle=True)
        d.attrs["units"] = "kg m-3"
        fields.create_dataset("density_f64", data=data.astype(np.float64))
        f.create_dataset("counts", data=counts)
        f.create_dataset("map", data=data[0])


def write_npz(out, data):
    x = CENTRE0[0] + SPACING[0] * np.arange(NX)
    arrays = dict(density=data, counts=count_values(), map=data[0], x=x)
    np.savez(os.path.join(out, "npz_stored.npz"), **arrays)
    np.savez_compressed(os.path.join(out, "npz_deflated.npz"), **arrays)
    member = io.BytesIO()
    np.save(member, data)
    with zipfile.ZipFile(os.path.join(out, "npz_bzip2.npz"), "w", zipfile.ZIP_BZIP2) as z:
        z.writestr("density.npy", member.getvalue())


def main():
    out = sys.argv[1]
    data = values()
    np.save(os.path.join(out, "expect.npy"), data)
    write_vti(out, data)
    write_legacy(out, data)
    write_nrrd(out, data)
    write_hdf5(out, data)
    write_npz(out, data)


if __name__ == "__main__":
    main()
