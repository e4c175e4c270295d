#!/usr/bin/env python3
"""Peer benchmark: VTK's volume mappers on hdrvis's volume, image size and step.

`hdrvis bench volume --peer vtk` runs this script as a subprocess, once per mapper, and compares
its median frame time with hdrvis's own volume ray caster:
- `--mapper gpu`: vtkGPUVolumeRayCastMapper, which must run on the same software rasterizer as
  hdrvis (Mesa llvmpipe), so the script forces VTK's offscreen EGL window and Mesa's software
  path, and refuses to report a timing from any other renderer unless told otherwise;
- `--mapper fixedpoint`: vtkFixedPointVolumeRayCastMapper, VTK's CPU ray caster (the one
  ParaView offers on CPU-only machines), on `--threads` threads. It skips empty space with a
  min-max volume of its own. It takes point data only, so its box is one voxel smaller (point
  samples at the voxel centres, spanning [0.5, n - 0.5]).

Scene, in hdrvis's conventions: voxels are cells, so an (nz, ny, nx) array spans [0, n] along each
axis with unit spacing; orthographic camera looking along -z with +y up, framing the x/y extent;
composite blending, trilinear interpolation, no shading, fixed sample distance, and no automatic
adjustment of sample or image distances.

Output: exactly one JSON line on stdout. Any failure: one line on stderr and exit status 2.
"""

import argparse
import json
import os
import statistics
import sys
import time

EXIT_UNAVAILABLE = 2


class PeerUnavailable(Exception):
    """Any reason the peer cannot produce an honest timing; reported as one stderr line."""


class OneLineArgumentParser(argparse.ArgumentParser):
    def error(self, message):
        raise PeerUnavailable(f"bad arguments: {message}")


def parse_args(argv):
    parser = OneLineArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--npy", required=True, help="float32 volume, shape (nz, ny, nx), C order")
    parser.add_argument("--width", type=int, required=True)
    parser.add_argument("--height", type=int, required=True)
    parser.add_argument("--sample-distance", type=float, default=1.0, help="world units (voxels)")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--tf", required=True, help="transfer function JSON")
    parser.add_argument("--save-png", help="write the last rendered frame here")
    parser.add_argument("--mapper", choices=["gpu", "fixedpoint"], default="gpu")
    parser.add_argument("--threads", type=int, default=2, help="fixedpoint: ray-casting threads")
    parser.add_argument(
        "--require-renderer",
        default="llvmpipe",
        help="substring the GL renderer string must contain (empty: accept any)",
    )
    args = parser.parse_args(argv)
    if not (1 <= args.width <= 16384 and 1 <= args.height <= 16384):
        raise PeerUnavailable(f"width/height must be in 1..=16384, got {args.width}x{args.height}")
    if not (args.sample_distance > 0.0 and args.sample_distance < float("inf")):
        raise PeerUnavailable(f"sample-distance must be finite and > 0, got {args.sample_distance}")
    if not 1 <= args.runs <= 1000:
        raise PeerUnavailable(f"runs must be in 1..=1000, got {args.runs}")
    return args


def select_offscreen_egl():
    """Must run before vtk is imported: VTK picks its window class when the module loads."""
    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    # A machine with a GPU would otherwise hand EGL to the vendor driver; the comparison is
    # software rasterizer against software rasterizer.
    os.environ.setdefault("LIBGL_ALWAYS_SOFTWARE", "1")
    os.environ.setdefault("GALLIUM_DRIVER", "llvmpipe")
    mesa_vendor = "/usr/share/glvnd/egl_vendor.d/50_mesa.json"
    if os.path.exists(mesa_vendor):
        os.environ.setdefault("__EGL_VENDOR_LIBRARY_FILENAMES", mesa_vendor)


def load_volume(path, np):
    try:
        data = np.load(path, mmap_mode=None, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise PeerUnavailable(f"cannot read volume {path}: {e}") from e
    if data.ndim != 3:
        raise PeerUnavailable(f"{path}: expected a 3-D array (nz, ny, nx), got shape {data.shape}")
    if data.dtype != np.float32:
        raise PeerUnavailable(f"{path}: expected float32, got {data.dtype}")
    return np.ascontiguousarray(data)


def load_transfer_function(path):
    try:
        with open(path, encoding="utf-8") as f:
            tf = json.load(f)
    except (OSError, ValueError) as e:
        raise PeerUnavailable(f"cannot read transfer function {path}: {e}") from e
    color = tf.get("color")
    opacity = tf.get("opacity")
    if not (isinstance(color, list) and color and all(_is_numbers(p, 4) for p in color)):
        raise PeerUnavailable(f"{path}: 'color' must be a non-empty list of [value, r, g, b]")
    if not (isinstance(opacity, list) and opacity and all(_is_numbers(p, 2) for p in opacity)):
        raise PeerUnavailable(f"{path}: 'opacity' must be a non-empty list of [value, alpha]")
    unit = tf.get("scalar_opacity_unit_distance", 1.0)
    if not (isinstance(unit, (int, float)) and unit > 0):
        raise PeerUnavailable(f"{path}: 'scalar_opacity_unit_distance' must be > 0, got {unit}")
    return color, opacity, float(unit)


def _is_numbers(point, count):
    return (
        isinstance(point, list)
        and len(point) == count
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in point)
    )


def gl_strings(render_window):
    """Vendor, renderer and version as VTK's context reports them (after the first Render)."""
    found = {}
    for line in render_window.ReportCapabilities().splitlines():
        for key in ("vendor", "renderer", "version"):
            prefix = f"OpenGL {key} string:"
            if line.startswith(prefix):
                found[key] = line[len(prefix) :].strip()
    return found.get("vendor", "?"), found.get("renderer", "?"), found.get("version", "?")


def llvmpipe_threads():
    """llvmpipe's rasterizer thread count: LP_NUM_THREADS, else one per CPU (Mesa caps it at 16)."""
    configured = os.environ.get("LP_NUM_THREADS", "")
    if configured.isdigit():
        return int(configured)
    return min(os.cpu_count() or 1, 16)


def build_image_data(volume, image_data_type, numpy_support, cells):
    nz, ny, nx = volume.shape
    image = image_data_type()
    image.SetSpacing(1.0, 1.0, 1.0)
    # C order (nz, ny, nx) ravels x-fastest, which is VTK's order; no copy.
    scalars = numpy_support.numpy_to_vtk(volume.reshape(-1), deep=0)
    scalars.SetName("values")
    if cells:
        # Cell data on an (n+1)-point grid: the box spans [0, n] and each value sits at a cell
        # centre, the same geometry hdrvis uses, rather than point samples spanning [0, n-1].
        image.SetDimensions(nx + 1, ny + 1, nz + 1)
        image.SetOrigin(0.0, 0.0, 0.0)
        image.GetCellData().SetScalars(scalars)
    else:
        # Point data at the voxel centres (the fixed-point mapper reads no cell data).
        image.SetDimensions(nx, ny, nz)
        image.SetOrigin(0.5, 0.5, 0.5)
        image.GetPointData().SetScalars(scalars)
    return image


def render_benchmark(args):
    select_offscreen_egl()
    try:
        import numpy as np
    except ImportError as e:
        raise PeerUnavailable(f"numpy not installed: {e}") from e
    try:
        # Imported for their side effect: they register the OpenGL window and GPU mapper factories.
        import vtkmodules.vtkRenderingOpenGL2
        import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
        from vtkmodules.util import numpy_support
        from vtkmodules.vtkCommonCore import (
            vtkLogger,
            vtkOutputWindow,
            vtkStringOutputWindow,
            vtkVersion,
        )
        from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
        from vtkmodules.vtkIOImage import vtkPNGWriter
        from vtkmodules.vtkRenderingCore import (
            vtkColorTransferFunction,
            vtkRenderer,
            vtkRenderWindow,
            vtkVolume,
            vtkVolumeProperty,
            vtkWindowToImageFilter,
        )
        from vtkmodules.vtkRenderingVolume import (
            vtkFixedPointVolumeRayCastMapper,
            vtkGPUVolumeRayCastMapper,
        )
    except ImportError as e:
        raise PeerUnavailable(f"vtk not installed: {e}") from e

    # stdout carries exactly one JSON line and stderr at most one reason line, so VTK's own
    # messages are collected instead of printed, and quoted when they explain a failure.
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    vtk_messages = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(vtk_messages)

    def first_vtk_message():
        for line in vtk_messages.GetOutput().splitlines():
            line = line.strip()
            if line and not line.startswith(("Warning: In", "Generic Warning: In", "ERROR: In")):
                return f" (VTK: {line})"
        return ""

    volume = load_volume(args.npy, np)
    color_points, opacity_points, unit_distance = load_transfer_function(args.tf)
    nz, ny, nx = volume.shape
    gpu = args.mapper == "gpu"
    image = build_image_data(volume, vtkImageData, numpy_support, cells=gpu)

    color = vtkColorTransferFunction()
    for value, r, g, b in color_points:
        color.AddRGBPoint(value, r, g, b)
    opacity = vtkPiecewiseFunction()
    for value, alpha in opacity_points:
        opacity.AddPoint(value, alpha)

    prop = vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(unit_distance)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()

    if gpu:
        mapper = vtkGPUVolumeRayCastMapper()
        mapper.SetScalarModeToUseCellData()
        mapper.SetUseJittering(0)
    else:
        if not 1 <= args.threads <= 256:
            raise PeerUnavailable(f"threads must be in 1..=256, got {args.threads}")
        mapper = vtkFixedPointVolumeRayCastMapper()
        mapper.SetScalarModeToUsePointData()
        mapper.SetNumberOfThreads(args.threads)
        # Its interactive sample distance would otherwise replace the still one while rendering.
        mapper.SetInteractiveSampleDistance(args.sample_distance)
    mapper.SetInputData(image)
    mapper.SetBlendModeToComposite()
    # Every knob that could change the step or the image resolution behind our back is pinned.
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetLockSampleDistanceToInputSpacing(0)
    mapper.SetSampleDistance(args.sample_distance)
    mapper.SetImageSampleDistance(1.0)
    mapper.SetMinimumImageSampleDistance(1.0)
    mapper.SetMaximumImageSampleDistance(1.0)

    actor = vtkVolume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)

    renderer = vtkRenderer()
    renderer.SetBackground(0.0, 0.0, 0.0)
    renderer.AddVolume(actor)

    window = vtkRenderWindow()
    window_class = window.GetClassName()
    if window_class != "vtkEGLRenderWindow":
        raise PeerUnavailable(
            f"VTK gave {window_class}, not vtkEGLRenderWindow (no usable EGL){first_vtk_message()}"
        )
    window.SetOffScreenRendering(1)
    window.SetMultiSamples(0)
    window.SetSize(args.width, args.height)
    window.AddRenderer(renderer)
    # Interactive-rate logic only engages through auto-adjust; ask for the still rate anyway.
    window.SetDesiredUpdateRate(0.0001)

    camera = renderer.GetActiveCamera()
    camera.ParallelProjectionOn()
    center = (nx / 2.0, ny / 2.0, nz / 2.0)
    camera.SetFocalPoint(*center)
    camera.SetPosition(center[0], center[1], center[2] + 2.0 * max(nx, ny, nz))
    camera.SetViewUp(0.0, 1.0, 0.0)
    # Parallel scale is half the visible height; fit the whole x/y extent whatever the aspect.
    camera.SetParallelScale(max(ny / 2.0, (nx / 2.0) * args.height / args.width))
    renderer.ResetCameraClippingRange()

    grabber = vtkWindowToImageFilter()
    grabber.SetInput(window)
    grabber.SetInputBufferTypeToRGB()
    grabber.ReadFrontBufferOff()
    grabber.ShouldRerenderOff()

    def render_and_read_back():
        # A camera change makes every layer treat the frame as new; the pixel readback waits for
        # the rasterizer to finish, so the time covers the whole frame.
        camera.Modified()
        window.Render()
        grabber.Modified()
        grabber.Update()

    try:
        render_and_read_back()  # warm-up: context, shader compile, volume and table upload
    except Exception as e:  # VTK raises little; a failed context shows up in the strings below
        raise PeerUnavailable(f"first render failed: {e}{first_vtk_message()}") from e
    gl_vendor, gl_renderer, gl_version = gl_strings(window)
    if args.require_renderer and args.require_renderer not in gl_renderer:
        raise PeerUnavailable(
            f"GL renderer is '{gl_renderer}', not {args.require_renderer}: an unfair comparison"
        )
    frame = grabber.GetOutput()
    got = frame.GetDimensions()[:2]
    if frame.GetNumberOfPoints() == 0:
        raise PeerUnavailable(f"no image came back from the first render{first_vtk_message()}")
    if tuple(got) != (args.width, args.height):
        raise PeerUnavailable(f"VTK rendered {got[0]}x{got[1]}, not {args.width}x{args.height}")
    if mapper.GetSampleDistance() != args.sample_distance:
        raise PeerUnavailable(f"VTK changed the sample distance to {mapper.GetSampleDistance()}")

    runs_ms = []
    # llvmpipe's raster threads live in this process, so process CPU time is the work done; on a
    # loaded machine it stays meaningful when wall time does not.
    cpu_runs_ms = []
    for _ in range(args.runs):
        cpu_start = time.process_time()
        start = time.perf_counter()
        render_and_read_back()
        runs_ms.append((time.perf_counter() - start) * 1e3)
        cpu_runs_ms.append((time.process_time() - cpu_start) * 1e3)

    if args.save_png:
        writer = vtkPNGWriter()
        writer.SetFileName(args.save_png)
        writer.SetInputData(grabber.GetOutput())
        writer.Write()
        if writer.GetErrorCode():
            raise PeerUnavailable(f"cannot write {args.save_png}")

    return {
        "peer": "vtk",
        "mapper": mapper.GetClassName(),
        "threads": args.threads if not gpu else None,
        "vtk_version": vtkVersion.GetVTKVersion(),
        "gl_renderer": gl_renderer,
        "gl_vendor": gl_vendor,
        "gl_version": gl_version,
        "median_ms": round(statistics.median(runs_ms), 3),
        "runs_ms": [round(t, 3) for t in runs_ms],
        "cpu_median_ms": round(statistics.median(cpu_runs_ms), 3),
        "cpu_runs_ms": [round(t, 3) for t in cpu_runs_ms],
        "raster_threads": llvmpipe_threads(),
        "width": args.width,
        "height": args.height,
        "sample_distance": args.sample_distance,
        "dims": [nx, ny, nz],
    }


def main(argv):
    try:
        result = render_benchmark(parse_args(argv))
    except PeerUnavailable as e:
        print(str(e).replace("\n", " "), file=sys.stderr)
        return EXIT_UNAVAILABLE
    except MemoryError:
        print("out of memory loading or uploading the volume", file=sys.stderr)
        return EXIT_UNAVAILABLE
    except Exception as e:  # noqa: BLE001  (hdrvis reads one reason line, whatever went wrong)
        print(f"{type(e).__name__}: {e}".replace("\n", " "), file=sys.stderr)
        return EXIT_UNAVAILABLE
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
