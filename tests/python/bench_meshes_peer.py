#!/usr/bin/env python3
"""Peer benchmark: GeoVista (PyVista/VTK) drawing an MPAS mesh, beside `hdrvis bench meshes`.

    python3 tests/python/bench_meshes_peer.py MPAS_FILE WIDTH HEIGHT RUNS OUT.png
        [--var temperature] [--cmap viridis] [--require-renderer SUBSTRING]

`hdrvis bench meshes` runs this script as a subprocess on the same mesh file and image size it
draws itself, and sets the timings side by side. MPAS_FILE is an MPAS-style NetCDF (as MPAS writes
it, NetCDF-3 64-bit offset, or NetCDF-4) with latVertex/lonVertex(nVertices) in radians,
nEdgesOnCell(nCells), verticesOnCell(nCells, maxEdges) 1-based and 0-padded past nEdgesOnCell,
and a cell field (default `temperature`; a field with more dimensions than nCells, such as
(Time, nCells, nVertLevels), is taken at index 0 of each other dimension).

What is timed, each phase once except the redraws:
- load_s: netCDF4 reads the coordinates, the connectivity and the field;
- mesh_s: geovista.Transform.from_unstructured builds the spherical mesh (vertices in degrees,
  connectivity 0-based and masked past each cell's nEdgesOnCell);
- first_draw_s: GeoPlotter(crs="+proj=eqc", off_screen=True) (the OpenGL context), add_mesh
  (GeoVista slices the cells on the antimeridian and projects them to plate carree), view_xy with
  the camera fitted to the map (orthographic, no padding), and the first render with its
  screenshot written to OUT.png; first_draw_parts splits it;
- redraw_s: RUNS times render() + screenshot(OUT.png) of the same scene (the mesh is already on
  the GPU, so this is rasterization, the pixel readback and the PNG encoding); redraw_render_s
  is the render() part of each alone.
peak_mib is the process's peak resident set (getrusage's ru_maxrss).

Rendering is offscreen and headless: VTK's EGL window on Mesa, forced onto the software
rasterizer (llvmpipe) as the VTK volume peer does (tests/python/vtk_volume_bench.py), unless
LIBGL_ALWAYS_SOFTWARE / GALLIUM_DRIVER are already set. The renderer string VTK got is reported;
--require-renderer refuses any other (empty, the default: accept any).

Output: exactly one JSON line on stdout:
    {"tool": "geovista X.Y.Z", "pyvista": ..., "vtk": ..., "renderer": ..., "cells": n,
     "width": w, "height": h, "load_s": .., "mesh_s": .., "first_draw_s": ..,
     "first_draw_parts": {...}, "redraw_s": [...], "redraw_median_s": ..,
     "redraw_render_s": [...], "peak_mib": ..}
Exit status 77 with a one-line SKIP message on stderr when numpy, netCDF4, pyvista or geovista is
not installed (pip install -r tests/python/requirements-bench.txt); any other failure: one line on
stderr and exit status 2.
"""

import argparse
import json
import os
import resource
import statistics
import sys
import time

EXIT_SKIP = 77
EXIT_FAILED = 2


def select_offscreen_egl():
    """Must run before vtk (pyvista, geovista) is imported: VTK picks its window class on load."""
    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    os.environ.setdefault("LIBGL_ALWAYS_SOFTWARE", "1")
    os.environ.setdefault("GALLIUM_DRIVER", "llvmpipe")
    mesa_vendor = "/usr/share/glvnd/egl_vendor.d/50_mesa.json"
    if os.path.exists(mesa_vendor):
        os.environ.setdefault("__EGL_VENDOR_LIBRARY_FILENAMES", mesa_vendor)


select_offscreen_egl()

try:
    import numpy as np
    import netCDF4
    import pyvista as pv
    import geovista
    from vtkmodules.vtkCommonCore import vtkLogger, vtkOutputWindow, vtkStringOutputWindow
    from vtkmodules.vtkCommonCore import vtkVersion
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements-bench.txt)", file=sys.stderr)
    sys.exit(EXIT_SKIP)


def pyvista_compat():
    """GeoVista 0.5.3 (the newest release) reads `active_scalars_info._namedtuple`, which
    PyVista 0.45 removed when active_scalars_info became the named tuple itself (pyvista#6835;
    fixed on GeoVista's main by geovista#1219, not yet released). PyVista 0.44, the last without
    the change, needs vtk < 9.4, so the attribute is given back here: the tuple is its own
    `_namedtuple`. Also quiets PyVista's deprecation warnings on GeoVista's private accesses."""
    import warnings

    info = getattr(getattr(pv, "core", None), "dataset", None)
    info = getattr(info, "ActiveArrayInfoTuple", None)
    if info is not None and not hasattr(info, "_namedtuple"):
        info._namedtuple = property(lambda self: self)
    deprecation = getattr(getattr(pv, "core", None), "errors", None)
    deprecation = getattr(deprecation, "PyVistaDeprecationWarning", None)
    if deprecation is not None:
        warnings.simplefilter("ignore", deprecation)


class PeerFailed(Exception):
    """Any reason the peer cannot produce an honest timing; reported as one stderr line."""


class OneLineArgumentParser(argparse.ArgumentParser):
    def error(self, message):
        raise PeerFailed(f"bad arguments: {message}")


def parse_args(argv):
    parser = OneLineArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mpas_file")
    parser.add_argument("width", type=int)
    parser.add_argument("height", type=int)
    parser.add_argument("runs", type=int)
    parser.add_argument("out_png")
    parser.add_argument("--var", default="temperature", help="cell field to colour by")
    parser.add_argument("--cmap", default="viridis")
    parser.add_argument("--require-renderer", default="",
                        help="substring the GL renderer string must contain (empty: any)")
    args = parser.parse_args(argv)
    if not (1 <= args.width <= 16384 and 1 <= args.height <= 16384):
        raise PeerFailed(f"width/height must be in 1..=16384, got {args.width}x{args.height}")
    if not 0 <= args.runs <= 1000:
        raise PeerFailed(f"runs must be in 0..=1000, got {args.runs}")
    return args


def read_var(ds, name):
    if name not in ds.variables:
        raise PeerFailed(f"{ds.filepath()}: no variable {name}")
    var = ds.variables[name]
    var.set_auto_mask(False)
    return var


def load_mpas(path, field_name):
    """The vertices (degrees), 0-based masked connectivity and the cell field."""
    try:
        ds = netCDF4.Dataset(path, "r")
    except OSError as e:
        raise PeerFailed(f"cannot open {path}: {e}") from e
    with ds:
        lon = np.degrees(read_var(ds, "lonVertex")[:].astype(np.float64))
        lat = np.degrees(read_var(ds, "latVertex")[:].astype(np.float64))
        n_edges = read_var(ds, "nEdgesOnCell")[:].astype(np.int64)
        voc = read_var(ds, "verticesOnCell")[:].astype(np.int64)
        field_var = read_var(ds, field_name)
        dims = field_var.dimensions
        if "nCells" not in dims:
            raise PeerFailed(f"{path}: {field_name} has dimensions {dims}, none of them nCells")
        index = tuple(slice(None) if d == "nCells" else 0 for d in dims)
        field = np.asarray(field_var[index], dtype=np.float64)
        fill = getattr(field_var, "_FillValue", None)
        if fill is not None:
            field = np.where(field == fill, np.nan, field)
    n_cells, max_edges = voc.shape
    if n_edges.shape != (n_cells,) or field.shape != (n_cells,):
        raise PeerFailed(f"{path}: nEdgesOnCell {n_edges.shape}, {field_name} {field.shape}, "
                         f"verticesOnCell {voc.shape} disagree on nCells")
    conn = voc - 1
    padding = (np.arange(max_edges)[None, :] >= n_edges[:, None]) | (conn < 0)
    if np.any(conn[~padding] >= len(lon)):
        raise PeerFailed(f"{path}: verticesOnCell points past nVertices={len(lon)}")
    conn = np.ma.masked_array(np.where(padding, 0, conn), mask=padding)
    return lon, lat, conn, field


def fit_map(plotter, aspect):
    """view_xy, made orthographic and fitted as a 2-D map is drawn: the projected mesh's box
    fills the image along its tighter axis (a 2:1 map touches all four sides of a 2:1 image),
    instead of view_xy's padded perspective view."""
    plotter.enable_parallel_projection()
    plotter.view_xy()  # centres the camera on the bounds, looking down -z with +y up
    x0, x1, y0, y1, _, _ = plotter.renderer.bounds
    plotter.camera.parallel_scale = max((y1 - y0) / 2.0, (x1 - x0) / 2.0 / aspect)
    plotter.renderer.reset_camera_clipping_range()


def gl_renderer(render_window):
    for line in render_window.ReportCapabilities().splitlines():
        prefix = "OpenGL renderer string:"
        if line.startswith(prefix):
            return line[len(prefix):].strip()
    return "?"


def bench(args):
    # stdout carries exactly one JSON line: VTK's own messages are collected, not printed, and
    # quoted when they explain a failure.
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    vtk_messages = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(vtk_messages)

    def first_vtk_message():
        for line in vtk_messages.GetOutput().splitlines():
            line = line.strip()
            if line and not line.startswith(("Warning: In", "Generic Warning: In", "ERROR: In")):
                return f" (VTK: {line})"
        return ""

    pv.OFF_SCREEN = True
    pyvista_compat()

    start = time.perf_counter()
    lon, lat, conn, field = load_mpas(args.mpas_file, args.var)
    load_s = time.perf_counter() - start

    start = time.perf_counter()
    mesh = geovista.Transform.from_unstructured(lon, lat, connectivity=conn, data=field,
                                                start_index=0, name=args.var)
    mesh_s = time.perf_counter() - start
    if mesh.n_cells != len(field):
        raise PeerFailed(f"GeoVista built {mesh.n_cells} cells from {len(field)}")

    start = time.perf_counter()
    plotter = geovista.GeoPlotter(crs="+proj=eqc", off_screen=True,
                                  window_size=(args.width, args.height))
    window_class = plotter.ren_win.GetClassName()
    if window_class not in ("vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"):
        raise PeerFailed(f"VTK gave {window_class}, not an offscreen EGL/OSMesa window"
                         f"{first_vtk_message()}")
    plotter_s = time.perf_counter() - start
    t = time.perf_counter()
    # Unlit, as a map is coloured: the colormap's own colours, not shaded by the light kit.
    plotter.add_mesh(mesh, cmap=args.cmap, show_scalar_bar=False, lighting=False)
    add_mesh_s = time.perf_counter() - t
    t = time.perf_counter()
    fit_map(plotter, args.width / args.height)
    try:
        image = plotter.screenshot(args.out_png, return_img=True)
    except Exception as e:  # a failed context shows up in VTK's messages
        raise PeerFailed(f"first render failed: {e}{first_vtk_message()}") from e
    render_s = time.perf_counter() - t
    first_draw_s = time.perf_counter() - start

    renderer = gl_renderer(plotter.ren_win)
    if args.require_renderer and args.require_renderer not in renderer:
        raise PeerFailed(f"GL renderer is '{renderer}', not {args.require_renderer}")
    if image is None or image.shape[:2] != (args.height, args.width):
        got = None if image is None else f"{image.shape[1]}x{image.shape[0]}"
        raise PeerFailed(f"GeoVista drew {got}, not {args.width}x{args.height}")

    redraw_s = []
    redraw_render_s = []
    for _ in range(args.runs):
        t = time.perf_counter()
        plotter.render()
        rendered = time.perf_counter()
        plotter.screenshot(args.out_png)
        redraw_s.append(time.perf_counter() - t)
        redraw_render_s.append(rendered - t)
    plotter.close()

    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {
        "tool": f"geovista {geovista.__version__}",
        "pyvista": pv.__version__,
        "vtk": vtkVersion.GetVTKVersion(),
        "renderer": renderer,
        "window": window_class,
        "cells": int(len(field)),
        "width": args.width,
        "height": args.height,
        "load_s": round(load_s, 6),
        "mesh_s": round(mesh_s, 6),
        "first_draw_s": round(first_draw_s, 6),
        "first_draw_parts": {
            "plotter_s": round(plotter_s, 6),
            "add_mesh_s": round(add_mesh_s, 6),
            "render_screenshot_s": round(render_s, 6),
        },
        "redraw_s": [round(s, 6) for s in redraw_s],
        "redraw_median_s": round(statistics.median(redraw_s), 6) if redraw_s else None,
        "redraw_render_s": [round(s, 6) for s in redraw_render_s],
        "peak_mib": round(peak_mib, 1),
    }


def main(argv):
    try:
        result = bench(parse_args(argv))
    except PeerFailed as e:
        print(str(e).replace("\n", " "), file=sys.stderr)
        return EXIT_FAILED
    except MemoryError:
        print("out of memory building or drawing the mesh", file=sys.stderr)
        return EXIT_FAILED
    except Exception as e:  # noqa: BLE001  (hdrvis reads one reason line, whatever went wrong)
        print(f"{type(e).__name__}: {e}".replace("\n", " "), file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
