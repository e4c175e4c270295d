"""Re-makes the gallery (docs/gallery.md, docs/gallery/): runs every example script with
`hdrvis run` into a scratch folder, keeps one figure of each (at most 480 px wide), and records
each script's SHA-256 in docs/gallery/manifest.tsv. The test `gallery::the_gallery_is_in_step_with_the_scripts`
fails when a script changes without the gallery being re-made, and when a script is neither shown
nor listed as left out.

Usage: python3 tools/gallery.py [HDRVIS]   (default: target/release/hdrvis; needs Pillow)
"""
import glob
import hashlib
import os
import subprocess
import sys
import tempfile

from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "docs", "gallery")
WIDTH = 480

# (script, the figure it writes (a glob under its output folder; the first match in name order),
# the caption). A figure of "-" leaves the script out, the caption saying why. Every script runs
# from the repository's root with --allow-path datasets/fixtures (the fixtures some read).
ENTRIES = [
    ("demo.rhai", "demo_ev0*.png",
     "The built-in demo: a mantle-like spherical shell, one HDR render shown at 0 EV."),
    ("mantle.rhai", "mantle_tonemapped.png",
     "The paper's case III (Fig. 5): mantle convection, tone-mapped (Reinhard local) with its colour bar."),
    ("fault.rhai", "fault_uz.png",
     "The paper's case II (Fig. 4): the vertical displacement of a buried normal fault as interference fringes."),
    ("nu_sweep.rhai", "nu_sweep/*.png",
     "A sweep over ν on the fault's uplift: a framed map with axes, colour bar and fringe legend."),
    ("tsunami.rhai", "tsunami_cyclic.png",
     "The paper's case I (Fig. 3): maximum tsunami height over a basin as a framed fringe map."),
    ("tsunami_series.rhai", "series/*.png",
     "One frame of a sea-surface-height series sharing one colour range across the movie."),
    ("tomography.rhai", "tomography.png",
     "A tomography-like model: cut-away globe with fringes and depth rings on the faces, coastlines and graticule."),
    ("mesh_icon.rhai", "mesh_icon.png",
     "An ICON-like icosahedral mesh (5120 triangles, as CDI writes ICON output) drawn cell by cell on the globe: salinity in direct colours, each triangle a flat facet with its edges, coastlines and a 30° graticule."),
    ("mesh_mpas.rhai", "mesh_mpas.png",
     "An MPAS Voronoi mesh (2562 hexagons and pentagons, the mesh in its own grid file) drawn cell by cell on a framed world map: temperature as fringes stepping from cell to cell, with coastlines."),
    ("mesh_coastal.rhai", "mesh_coastal.png",
     "An FVCOM coastal triangle mesh of Massachusetts and Cape Cod Bays fitted to the coastlines, drawn cell by cell: depth linear over each triangle as fringes, one per 10 m, with the triangles' edges on a framed map, land missing."),
    ("skin_temperature.rhai", "skin_temperature.png",
     "ECMWF skin temperature (the sea surface's over the ocean) from a real GRIB 1 file on 5°, in Robinson's projection with coastlines, a 30° graticule and a colour bar captioned with what it measures."),
    ("warming_anomaly.rhai", "warming_anomaly.png",
     "An anomaly in one line: HadCM3's air temperature over North America in 2097 less its 2068–2097 mean (a reduction over the file's time steps), in a Lambert conformal projection with a diverging map centred on zero and labelled contours."),
    ("wind_map.rhai", "wind_map.png",
     "The NCEP/NCAR reanalysis's January wind at 200 hPa: speed in colour, direction as arrows every 28 px with a reference arrow, over coastlines on a framed map."),
    ("orbit.rhai", "orbit/*.png",
     "A camera orbit around the mantle: the first of eight views."),
    ("exposure_tf_sweep.rhai", "tf_sweep/*.png",
     "An opacity and exposure sweep on the mantle: one view of the bracket."),
    ("large_volume.rhai", "large/out_of_core.png",
     "A volume opened as bricks and rendered out of core."),
    ("sweep_slurm.rhai", "-",
     "The orbit of orbit.rhai shared out over a Slurm job array: the same pictures."),
    ("tui_demo.rhai", "-",
     "The interactive scene of `hdrvis tui`: its pictures are the viewer's."),
]


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def main(argv):
    hdrvis = argv[0] if argv else os.path.join(ROOT, "target", "release", "hdrvis")
    listed = {e[0] for e in ENTRIES}
    scripts = sorted(os.path.basename(p) for p in glob.glob(os.path.join(ROOT, "scripts", "*.rhai")))
    unlisted = [s for s in scripts if s not in listed]
    if unlisted:
        sys.exit(f"scripts not in tools/gallery.py's ENTRIES: {', '.join(unlisted)}")
    os.makedirs(OUT, exist_ok=True)
    rows = []
    for script, pattern, caption in ENTRIES:
        path = os.path.join(ROOT, "scripts", script)
        image = "-"
        if pattern != "-":
            with tempfile.TemporaryDirectory() as scratch:
                subprocess.run([hdrvis, "run", path, "--out", scratch,
                                "--allow-path", "datasets/fixtures"],
                               check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
                found = sorted(glob.glob(os.path.join(scratch, pattern)))
                if not found:
                    sys.exit(f"{script} wrote no {pattern}")
                picture = Image.open(found[0]).convert("RGBA")
                if picture.width > WIDTH:
                    height = round(picture.height * WIDTH / picture.width)
                    picture = picture.resize((WIDTH, height), Image.LANCZOS)
                image = script.replace(".rhai", ".png")
                picture.save(os.path.join(OUT, image), optimize=True)
            print(f"{script}: {os.path.basename(found[0])} -> docs/gallery/{image}")
        rows.append((script, sha256(path), image, caption))
    with open(os.path.join(OUT, "manifest.tsv"), "w") as f:
        f.write("# script\tsha256 of the script\tfigure\tcaption (made by tools/gallery.py)\n")
        for row in rows:
            f.write("\t".join(row) + "\n")
    lines = [
        "# Gallery",
        "",
        "One figure from each example script in `scripts/`, made by that script as it is today",
        "(`python3 tools/gallery.py` re-makes them all; a test fails when a script changes and",
        "the gallery is not re-made). Run any of them with `hdrvis run scripts/NAME.rhai --out out`.",
        "",
    ]
    for script, _, image, caption in rows:
        if image == "-":
            continue
        lines += [f"## `{script}`", "", caption, "", f"![{script}](gallery/{image})", ""]
    left = [(s, c) for s, _, i, c in rows if i == "-"]
    if left:
        lines += ["Not shown:", ""] + [f"- `{s}`: {c}" for s, c in left] + [""]
    with open(os.path.join(ROOT, "docs", "gallery.md"), "w") as f:
        f.write("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
