#!/usr/bin/env python3
"""Write small GRIB files with ecCodes (the `eccodes` wheel, whose `eccodeslib` carries the
library with its AEC, OpenJPEG and PNG codecs) and a JSON reference of what ecCodes reads from
them: the reference values of hdrvis's tests of GRIB files.

    python3 tests/python/write_grib_cases.py OUT_DIR

Every file is built from ecCodes samples by setting keys, then values: smooth, temperature-like
fields of the latitudes and longitudes ecCodes gives each grid, packed at 16 bits per value (no
randomness, nothing read from the network; the same ecCodes writes the same bytes). The files
(all under 3 kB) written into OUT_DIR:

  GRIB2, one message each (t at 500 hPa), the packings on a regular lat/lon grid of 25 x 13
  points (2.5 degrees, 60N..30N, 0E..60E, scanning west to east, north to south):
    grid_simple.grib2, grid_complex.grib2, grid_complex_spatial_differencing.grib2,
    grid_jpeg.grib2 (JPEG 2000), grid_png.grib2, grid_ccsds.grib2 (CCSDS/AEC)
  GRIB2, one message each, simple packing; the regular lat/lon grid is 13 x 7 points (2.5
  degrees, 60N..45N, 0E..30E, north to south):
    grid_simple_bitmap.grib2   t at 850 hPa with a bitmap: points 0, 14, 45, 46, 90 missing
                               (missingValue 9999)
    regular_gg.grib2           regular Gaussian N=8: 32 longitudes x 16 latitudes
    rotated_ll.grib2           2t on a rotated lat/lon 9 x 7 grid (2 degrees, rotated latitudes
                               6..-6, longitudes -8..8, so the stored first longitude is 352),
                               south pole of rotation (-30, 10), angle 0
    lambert.grib2              2t, Lambert conformal 9 x 7 as NCEP writes it (first point 20N
                               240E, LoV 265, LaD = Latin1 = Latin2 = 25, 100 km, south to north),
                               spherical earth (shapeOfTheEarth 6, 6371229 m)
    polar_stereographic.grib2  2t, north polar stereographic 9 x 7 (first point 60N 330E, LoV 0,
                               LaD 60, 200 km, south to north, shapeOfTheEarth 6); its sample
                               keeps ECMWF's local section 2 (localDefinitionNumber 1)
    mercator.grib2             2t, Mercator 9 x 7 (first point 10N 100E, LaD 20, 100 km, south
                               to north, shapeOfTheEarth 6)
  GRIB2 with several messages:
    forecast.grib2             8 messages, step 0 then step 6 h, each: t at 850, 500, 250 hPa
                               and u at 500 hPa (data time 2024-01-15 18 UTC, so step 6 is valid
                               on 2024-01-16 at 00 UTC)
    ensemble.grib2             4 messages: t at 500 hPa, product template 4.1,
                               perturbationNumber 0 (typeOfEnsembleForecast 0, the control) and
                               1..3 (type 3), numberOfForecastsInEnsemble 4
  GRIB1 (the samples carry ECMWF's local definition 1, MARS labelling, whose `number` ecCodes
  reports as perturbationNumber 0):
    grib1_regular_ll.grib1     t at 850 hPa, regular lat/lon 13 x 7, bitmap: points 3, 20, 21, 77
                               missing (missingValue 9999)
    grib1_gaussian.grib1       t at 500 hPa, regular Gaussian N=8 (32 x 16)
    grib1_multi.grib1          4 messages at step 12 h: t at 850, 500, 250 hPa and z at 500 hPa
    grib1_lambert.grib1        t at 850 hPa, Lambert conformal 9 x 7 (secant at 25 and 45N)
    grib1_polar_stereographic.grib1   t at 500 hPa, north polar stereographic 9 x 7
    grib1_south_polar_stereographic.grib1   t at 500 hPa, south polar stereographic 9 x 7
                               (projection centre flag 128, first point 50S 120E, LoV 150, 400 km)
    grib1_mercator.grib1       t at 850 hPa, Mercator 9 x 7 (first point 10N 100E, Latin 20, 100 km)
  Reduced Gaussian (ecCodes' reduced_gg_pl samples, N32: 64 rows of 20..128 points, 6114 in all):
    reduced_gg.grib1, reduced_gg.grib2 (the GRIB2 one with points 0, 1000 and 6113 missing)
  Model levels (typeOfLevel hybrid with the PV array of 7 half levels' A and B), regular 13 x 7:
    model_levels.grib2         t on levels 1..6 and lnsp on level 1 (as ECMWF writes them)
    model_levels.grib1         t on levels 1..6 and sp on the surface

and reference.json (compact JSON):

  {"eccodes": {"library": "2.50.0", "python": "2.44.0"},
   "files": [{"file": NAME, "edition": 1|2, "count": N, "messages": [MESSAGE, ...]}, ...],
   "model_levels": {NAME: {HPA: [float or null, ...]}}}

where "model_levels" holds t at each pressure of MODEL_LEVEL_TARGETS for each model-level file
(model_level_reference: linear in ln p, vinth2p's rule, null where no column brackets it), and
the files are in the order above, where each MESSAGE is an object of
  "file" (str), "message" (int, 0-based index in the file), "edition" (int), "shortName", "name",
  "units", "typeOfLevel" (str), "level" (int), "stepRange" (str), "step" (int, hours),
  "dataDate", "dataTime", "validityDate", "validityTime" (int, YYYYMMDD and HHMM),
  "perturbationNumber" (int or null when ecCodes has none for the message), "gridType",
  "packingType" (str), "Ni", "Nj" (int: points along a row and along a column; Nx and Ny for
  lambert and polar_stereographic), "numberOfDataPoints" (int: points of the grid),
  "numberOfValues" (int: values coded, the points less the missing ones), "numberOfMissing"
  (int), "bitmapPresent" (bool), "missingValue" (float), "bitsPerValue", "binaryScaleFactor",
  "decimalScaleFactor" (int), "referenceValue" (float), "precision" (float: 2^E / 10^D / 2,
  half a packing step, the largest difference between a value written and the value read),
  the code numbers "paramId", "localDefinitionNumber", for GRIB2 "discipline",
  "parameterCategory", "parameterNumber", "typeOfFirstFixedSurface",
  "gridDefinitionTemplateNumber", "productDefinitionTemplateNumber",
  "dataRepresentationTemplateNumber", "typeOfEnsembleForecast", "numberOfForecastsInEnsemble",
  for GRIB1 "table2Version", "indicatorOfParameter", "indicatorOfTypeOfLevel",
  "dataRepresentationType" (each int or null: null where the message is of the other edition
  or ecCodes does not define the key), "grid" (object: the grid's own keys, ecCodes key name to
  int or float, those of GRID_KEYS[gridType] the message has), "values" (list of float or null:
  as ecCodes reads them, in the message's scanning order, null at missing points), "latitudes"
  and "longitudes" (lists of float: ecCodes' geographic coordinates of each point in the same
  order; for rotated_ll ecCodes rounds them to 1e-6 degrees; longitudes as ecCodes gives them,
  in [-180, 180) for rotated_ll and in [0, 360) for the others).
  Reduced grids add "pl" (points per row) and "regular": {"Ni", "values", "latitudes",
  "longitudes"}, the values on the regular grid of max(pl) longitudes per row, each row filled by
  numpy's periodic linear interpolation of ecCodes' values (null next to a missing point).
  The south-polar GRIB1 grid's "latitudes" and "longitudes" are PROJ's (pyproj, `stere` with
  lat_0=-90, lat_ts=-60 on R = 6367470 m, in a subprocess), ecCodes' kept as
  "eccodes_latitudes"/"eccodes_longitudes": ecCodes 2.50 places such grids as if north-polar.
Floats are Python floats (doubles), written by `json` with repr, so they read back exactly.

The script also checks its files: each opens, has its count of messages, its missing points
where they were written, and every value ecCodes reads back within `precision` of the value
written; it prints a table of the files and exits 1 when a check fails.
Exit status 77 (skipped) when a module is missing.
"""

import json
import math
import os
import subprocess
import sys

try:
    import eccodes as ec
    import numpy as np
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)

MISSING = 9999.0
BITS = 16
DATE, TIME = 20240115, 1800

# The regular lat/lon grid of most cases: 13 x 7 points, 2.5 degrees, north to south.
REGULAR_LL = {
    "Ni": 13,
    "Nj": 7,
    "iScansNegatively": 0,
    "jScansPositively": 0,
    "latitudeOfFirstGridPointInDegrees": 60.0,
    "longitudeOfFirstGridPointInDegrees": 0.0,
    "latitudeOfLastGridPointInDegrees": 45.0,
    "longitudeOfLastGridPointInDegrees": 30.0,
    "iDirectionIncrementInDegrees": 2.5,
    "jDirectionIncrementInDegrees": 2.5,
}

# The packing cases' grid: 25 x 13 points, 2.5 degrees, 60N..30N, 0E..60E. Larger than
# REGULAR_LL for grid_png: ecCodes writes the PNG image into a buffer the size of the raw samples
# (Ni Nj bitsPerValue/8 bytes) and fails ("libpng error: Failed to write PNG data") when the PNG,
# with its ~60 bytes of chunks, is larger, as it is for 13 x 7 (and 17 x 9) points at 16 bits.
PACKING_LL = dict(
    REGULAR_LL,
    Ni=25,
    Nj=13,
    latitudeOfLastGridPointInDegrees=30.0,
    longitudeOfLastGridPointInDegrees=60.0,
)

# Keys reported under "grid" for each gridType (those the message has).
GRID_KEYS = {
    "regular_ll": [
        "Ni", "Nj", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "latitudeOfLastGridPointInDegrees", "longitudeOfLastGridPointInDegrees",
        "iDirectionIncrementInDegrees", "jDirectionIncrementInDegrees",
        "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
    "regular_gg": [
        "Ni", "Nj", "N", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "latitudeOfLastGridPointInDegrees", "longitudeOfLastGridPointInDegrees",
        "iDirectionIncrementInDegrees", "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
    "rotated_ll": [
        "Ni", "Nj", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "latitudeOfLastGridPointInDegrees", "longitudeOfLastGridPointInDegrees",
        "iDirectionIncrementInDegrees", "jDirectionIncrementInDegrees",
        "latitudeOfSouthernPoleInDegrees", "longitudeOfSouthernPoleInDegrees", "angleOfRotationInDegrees",
        "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
    "lambert": [
        "Nx", "Ny", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "LaDInDegrees", "LoVInDegrees", "Latin1InDegrees", "Latin2InDegrees",
        "latitudeOfSouthernPoleInDegrees", "longitudeOfSouthernPoleInDegrees",
        "DxInMetres", "DyInMetres", "projectionCentreFlag", "shapeOfTheEarth", "radius",
        "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
    "polar_stereographic": [
        "Nx", "Ny", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "LaDInDegrees", "orientationOfTheGridInDegrees", "DxInMetres", "DyInMetres",
        "projectionCentreFlag", "shapeOfTheEarth", "radius",
        "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
    "reduced_gg": [
        "N", "Nj", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "latitudeOfLastGridPointInDegrees", "longitudeOfLastGridPointInDegrees",
        "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
    "mercator": [
        "Ni", "Nj", "latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
        "latitudeOfLastGridPointInDegrees", "longitudeOfLastGridPointInDegrees",
        "LaDInDegrees", "orientationOfTheGridInDegrees", "DiInMetres", "DjInMetres",
        "shapeOfTheEarth", "radius", "iScansNegatively", "jScansPositively", "jPointsAreConsecutive",
    ],
}


def set_keys(h, keys):
    """Set `keys` in order (ints as ints, floats as doubles, strings as strings)."""
    for key, value in keys.items():
        if isinstance(value, float):
            ec.codes_set_double(h, key, value)
        elif isinstance(value, str):
            ec.codes_set_string(h, key, value)
        else:
            ec.codes_set_long(h, key, int(value))


def temperature(lats, lons, shift=0.0):
    """A smooth temperature-like field (kelvin) of the points' geographic coordinates."""
    lat, lon = np.radians(lats), np.radians(lons)
    return 250.0 + shift + 30.0 * np.cos(lat) + 5.0 * np.sin(2.0 * lon) * np.cos(3.0 * lat)


def coordinates(h):
    """ecCodes' latitudes and longitudes of the message's points (the grid's keys set), found
    by packing placeholder values first. GRIB2's numberOfDataPoints is not derived from the
    grid's dimensions: it is set here. A reduced grid keeps its sample's points."""
    if ec.codes_get(h, "gridType") == "reduced_gg":
        n = int(sum(ec.codes_get_array(h, "pl")))
    else:
        ni, nj = ("Nx", "Ny") if ec.codes_is_defined(h, "Nx") else ("Ni", "Nj")
        n = ec.codes_get(h, ni) * ec.codes_get(h, nj)
    if ec.codes_get(h, "edition") == 2:
        ec.codes_set_long(h, "numberOfDataPoints", n)
    ec.codes_set_values(h, np.linspace(0.0, 1.0, n))
    return ec.codes_get_array(h, "latitudes"), ec.codes_get_array(h, "longitudes")


def fill(h, field, missing=(), packing=None):
    """Pack `field(lats, lons)` at BITS bits per value, `missing` indices as MISSING (with a
    bitmap), in `packing` (set before the values; None keeps the sample's simple packing).
    Returns the values written, with NaN at the missing points."""
    ec.codes_set_long(h, "bitsPerValue", BITS)
    lats, lons = coordinates(h)
    values = np.asarray(field(lats, lons), dtype=float)
    if packing is not None:
        # Changing the packing repacks the placeholder values, and the complex packings leave
        # bitsPerValue at what the placeholder needed (5 bits): set it again, or the field is
        # packed at that precision (a step of 0.25 K).
        ec.codes_set_string(h, "packingType", packing)
        ec.codes_set_long(h, "bitsPerValue", BITS)
    if len(missing):
        ec.codes_set_double(h, "missingValue", MISSING)
        ec.codes_set_long(h, "bitmapPresent", 1)
        values[list(missing)] = MISSING
    ec.codes_set_values(h, values)
    written = values.copy()
    written[list(missing)] = np.nan
    return written


def grib2(sample="regular_ll_pl_grib2", **keys):
    h = ec.codes_grib_new_from_samples(sample)
    base = {"centre": "ecmf", "dataDate": DATE, "dataTime": TIME, "stepUnits": "h", "step": 0}
    base.update(keys)
    set_keys(h, base)
    return h


def level_keys(short_name, level, step, edition=2):
    """A parameter on an isobaric level at a forecast step in hours."""
    keys = {"typeOfLevel": "isobaricInhPa", "level": level, "shortName": short_name}
    if edition == 2:
        keys["stepUnits"] = "h"
    else:
        keys["unitOfTimeRange"] = 1  # hours
    keys["step"] = step
    return keys


# -- GRIB2 packings ------------------------------------------------------------------------------

# Every packing the wheel's library writes: grid_jpeg needs OpenJPEG (JPG), grid_png libpng (PNG)
# and grid_ccsds libaec (AEC), all in eccodeslib's codes_get_features().
PACKINGS = ["grid_simple", "grid_complex", "grid_complex_spatial_differencing", "grid_jpeg", "grid_png", "grid_ccsds"]


def packing_case(packing):
    h = grib2(**level_keys("t", 500, 0), **PACKING_LL)
    written = fill(h, temperature, packing=packing)
    return [(h, written)]


def bitmap_case():
    h = grib2(**level_keys("t", 850, 0), **REGULAR_LL)
    written = fill(h, temperature, missing=[0, 14, 45, 46, 90])
    return [(h, written)]


# -- GRIB2 grids ---------------------------------------------------------------------------------


def gaussian_keys(n):
    lat0 = float(ec.codes_get_gaussian_latitudes(n)[0])
    return {
        "Ni": 4 * n,
        "Nj": 2 * n,
        "N": n,
        "iScansNegatively": 0,
        "jScansPositively": 0,
        "latitudeOfFirstGridPointInDegrees": lat0,
        "longitudeOfFirstGridPointInDegrees": 0.0,
        "latitudeOfLastGridPointInDegrees": -lat0,
        "longitudeOfLastGridPointInDegrees": 360.0 - 90.0 / n,
        "iDirectionIncrementInDegrees": 90.0 / n,
    }


def regular_gg_case():
    h = grib2("regular_gg_pl_grib2", **level_keys("t", 500, 0), **gaussian_keys(8))
    return [(h, fill(h, temperature))]


def rotated_ll_case():
    keys = {
        "Ni": 9,
        "Nj": 7,
        "iScansNegatively": 0,
        "jScansPositively": 0,
        "latitudeOfFirstGridPointInDegrees": 6.0,
        "longitudeOfFirstGridPointInDegrees": 352.0,
        "latitudeOfLastGridPointInDegrees": -6.0,
        "longitudeOfLastGridPointInDegrees": 8.0,
        "iDirectionIncrementInDegrees": 2.0,
        "jDirectionIncrementInDegrees": 2.0,
        "latitudeOfSouthernPoleInDegrees": -30.0,
        "longitudeOfSouthernPoleInDegrees": 10.0,
        "angleOfRotationInDegrees": 0.0,
    }
    h = grib2("rotated_ll_sfc_grib2", shortName="2t", **keys)
    return [(h, fill(h, temperature))]


def lambert_case():
    h = grib2("regular_ll_sfc_grib2", gridDefinitionTemplateNumber=30, shortName="2t")
    set_keys(h, {
        "shapeOfTheEarth": 6,
        "Nx": 9,
        "Ny": 7,
        "latitudeOfFirstGridPointInDegrees": 20.0,
        "longitudeOfFirstGridPointInDegrees": 240.0,
        "LaDInDegrees": 25.0,
        "LoVInDegrees": 265.0,
        "Latin1InDegrees": 25.0,
        "Latin2InDegrees": 25.0,
        "latitudeOfSouthernPoleInDegrees": -90.0,
        "longitudeOfSouthernPoleInDegrees": 0.0,
        "DxInMetres": 100000.0,
        "DyInMetres": 100000.0,
        "projectionCentreFlag": 0,
        "iScansNegatively": 0,
        "jScansPositively": 1,
    })
    return [(h, fill(h, temperature))]


def polar_stereographic_case():
    h = grib2("polar_stereographic_sfc_grib2", shortName="2t")
    set_keys(h, {
        "shapeOfTheEarth": 6,
        "Nx": 9,
        "Ny": 7,
        "latitudeOfFirstGridPointInDegrees": 60.0,
        "longitudeOfFirstGridPointInDegrees": 330.0,
        "LaDInDegrees": 60.0,
        "orientationOfTheGridInDegrees": 0.0,
        "DxInMetres": 200000.0,
        "DyInMetres": 200000.0,
        "projectionCentreFlag": 0,
        "iScansNegatively": 0,
        "jScansPositively": 1,
    })
    return [(h, fill(h, temperature))]


def mercator_case():
    # GRIB2 stores the last point too; it is the first point moved by (Nx-1) Di and (Ny-1) Dj
    # along the projection's axes (a sphere of radius 6371229 m, shapeOfTheEarth 6).
    ni, nj, d, lad, lat1, lon1 = 9, 7, 100000.0, 20.0, 10.0, 100.0
    r = 6371229.0 * math.cos(math.radians(lad))
    y1 = r * math.log(math.tan(math.pi / 4 + math.radians(lat1) / 2))
    lat2 = math.degrees(2 * math.atan(math.exp((y1 + (nj - 1) * d) / r)) - math.pi / 2)
    lon2 = lon1 + math.degrees((ni - 1) * d / r)
    h = grib2("regular_ll_sfc_grib2", gridDefinitionTemplateNumber=10, shortName="2t")
    set_keys(h, {
        "shapeOfTheEarth": 6,
        "Ni": ni,
        "Nj": nj,
        "latitudeOfFirstGridPointInDegrees": lat1,
        "longitudeOfFirstGridPointInDegrees": lon1,
        "latitudeOfLastGridPointInDegrees": round(lat2, 6),
        "longitudeOfLastGridPointInDegrees": round(lon2, 6),
        "LaDInDegrees": lad,
        "orientationOfTheGridInDegrees": 0.0,
        "DiInMetres": d,
        "DjInMetres": d,
        "iScansNegatively": 0,
        "jScansPositively": 1,
    })
    return [(h, fill(h, temperature))]


# -- GRIB2 with several messages -----------------------------------------------------------------


def forecast_case():
    out = []
    for step in (0, 6):
        for short_name, level in (("t", 850), ("t", 500), ("t", 250), ("u", 500)):
            h = grib2(**level_keys(short_name, level, step), **REGULAR_LL)
            if short_name == "t":
                shift = -0.06 * (1000 - level) + 0.5 * step
                out.append((h, fill(h, lambda la, lo, s=shift: temperature(la, lo, s))))
            else:
                out.append((h, fill(h, lambda la, lo, s=step: 10.0 + 0.5 * s + 0.8 * (la - 45.0) + 0.1 * lo)))
    return out


def ensemble_case():
    out = []
    for member in range(4):
        h = grib2(productDefinitionTemplateNumber=1, **level_keys("t", 500, 0), **REGULAR_LL)
        set_keys(h, {
            "typeOfEnsembleForecast": 0 if member == 0 else 3,
            "perturbationNumber": member,
            "numberOfForecastsInEnsemble": 4,
        })
        out.append((h, fill(h, lambda la, lo, m=member: temperature(la, lo, 0.25 * m * (-1) ** m))))
    return out


# -- GRIB1 ---------------------------------------------------------------------------------------


def grib1(sample, short_name, level, step, grid, centre="ecmf"):
    h = ec.codes_grib_new_from_samples(sample)
    set_keys(h, {"centre": centre, "dataDate": DATE, "dataTime": TIME})
    set_keys(h, level_keys(short_name, level, step, edition=1))
    set_keys(h, grid)
    return h


def grib1_regular_ll_case():
    h = grib1("regular_ll_pl_grib1", "t", 850, 0, REGULAR_LL)
    return [(h, fill(h, temperature, missing=[3, 20, 21, 77]))]


def grib1_gaussian_case():
    h = grib1("regular_gg_pl_grib1", "t", 500, 0, gaussian_keys(8))
    return [(h, fill(h, temperature))]


def grib1_multi_case():
    out = []
    for short_name, level in (("t", 850), ("t", 500), ("t", 250), ("z", 500)):
        h = grib1("regular_ll_pl_grib1", short_name, level, 12, REGULAR_LL)
        if short_name == "t":
            out.append((h, fill(h, lambda la, lo, s=-0.06 * (1000 - level): temperature(la, lo, s))))
        else:
            out.append((h, fill(h, lambda la, lo: 54000.0 + 60.0 * (la - 45.0) + 5.0 * lo)))
    return out


def grib1_lambert_case():
    """GRIB1 Lambert conformal on the spherical Earth (R = 6367.47 km), secant at 25° and 45°N,
    as NCEP's Eta files lay it out."""
    h = grib1("GRIB1", "t", 850, 0, {
        "gridType": "lambert",
        "Nx": 9,
        "Ny": 7,
        "latitudeOfFirstGridPointInDegrees": 20.0,
        "longitudeOfFirstGridPointInDegrees": -120.0,
        "LoVInDegrees": -95.0,
        "DxInMetres": 120000,
        "DyInMetres": 120000,
        "Latin1InDegrees": 25.0,
        "Latin2InDegrees": 45.0,
        "projectionCenterFlag": 0,
        "iScansNegatively": 0,
        "jScansPositively": 1,
    }, centre="kwbc")
    return [(h, fill(h, temperature))]


def grib1_polar_case():
    """GRIB1 polar stereographic (north, true at 60°N) on the spherical Earth."""
    h = grib1("GRIB1", "t", 500, 0, {
        "gridType": "polar_stereographic",
        "Nx": 9,
        "Ny": 7,
        "latitudeOfFirstGridPointInDegrees": 40.0,
        "longitudeOfFirstGridPointInDegrees": -130.0,
        "orientationOfTheGridInDegrees": -105.0,
        "DxInMetres": 250000,
        "DyInMetres": 250000,
        "projectionCenterFlag": 0,
        "iScansNegatively": 0,
        "jScansPositively": 1,
    }, centre="kwbc")
    return [(h, fill(h, temperature))]


def grib1_south_polar_case():
    """GRIB1 polar stereographic centred on the south pole (projection centre flag 128), true
    at 60°S, an Antarctic grid."""
    h = grib1("GRIB1", "t", 500, 0, SOUTH_POLAR, centre="kwbc")
    return [(h, fill(h, temperature))]


SOUTH_POLAR = {
    "gridType": "polar_stereographic",
    "Nx": 9,
    "Ny": 7,
    "latitudeOfFirstGridPointInDegrees": -50.0,
    "longitudeOfFirstGridPointInDegrees": 120.0,
    "orientationOfTheGridInDegrees": 150.0,
    "DxInMetres": 400000,
    "DyInMetres": 400000,
    "projectionCenterFlag": 128,
    "iScansNegatively": 0,
    "jScansPositively": 1,
}


def south_polar_positions():
    """The south-polar grid's nodes by PROJ's polar stereographic (lat_0 = -90, true at 60°S) on
    GRIB1's sphere (R = 6367470 m): first point projected, then steps of Dx east and Dy north
    on the plane. ecCodes 2.50 is not the reference here: its iterator takes the hemisphere from
    the sign of LaD, which GRIB1 does not code, and places south-polar GRIB1 nodes as if the
    north pole were the centre (latitudes rise from -50° towards the equator along a row)."""
    # In a process of its own: the eccodes and pyproj wheels, loaded in this order into one
    # process, abort at exit (double free between their bundled libraries).
    script = """
import json, sys, numpy as np, pyproj
g = json.loads(sys.argv[1])
proj = pyproj.Proj(proj="stere", lat_0=-90, lat_ts=-60, lon_0=g["orientationOfTheGridInDegrees"],
                   R=6367470.0)
x0, y0 = proj(g["longitudeOfFirstGridPointInDegrees"], g["latitudeOfFirstGridPointInDegrees"])
i, j = np.meshgrid(np.arange(g["Nx"]), np.arange(g["Ny"]))
lons, lats = proj(x0 + i.ravel() * g["DxInMetres"], y0 + j.ravel() * g["DyInMetres"], inverse=True)
print(json.dumps([[float(v) for v in lats], [float(v % 360.0) for v in lons]]))
"""
    out = subprocess.run([sys.executable, "-c", script, json.dumps(SOUTH_POLAR)], check=True,
                         capture_output=True, text=True).stdout
    lats, lons = json.loads(out)
    return lats, lons


def grib1_mercator_case():
    """GRIB1 Mercator on GRIB1's sphere (R = 6367470 m), true at 20°N, 100 km steps."""
    ni, nj, d, latin, lat1, lon1 = 9, 7, 100000, 20.0, 10.0, 100.0
    r = 6367470.0 * math.cos(math.radians(latin))
    y1 = r * math.log(math.tan(math.pi / 4 + math.radians(lat1) / 2))
    lat2 = math.degrees(2 * math.atan(math.exp((y1 + (nj - 1) * d) / r)) - math.pi / 2)
    lon2 = lon1 + math.degrees((ni - 1) * d / r)
    h = grib1("GRIB1", "t", 850, 0, {
        "gridType": "mercator",
        "Ni": ni,
        "Nj": nj,
        "latitudeOfFirstGridPointInDegrees": lat1,
        "longitudeOfFirstGridPointInDegrees": lon1,
        "latitudeOfLastGridPointInDegrees": round(lat2, 3),
        "longitudeOfLastGridPointInDegrees": round(lon2, 3),
        "LaDInDegrees": latin,
        "DiInMetres": d,
        "DjInMetres": d,
        "iScansNegatively": 0,
        "jScansPositively": 1,
    }, centre="kwbc")
    return [(h, fill(h, temperature))]


def reduced_case(edition):
    """ecCodes' reduced Gaussian N32 sample (64 rows of 20 to 128 points, 6114 in all), 2t; the
    GRIB2 one with a bitmap (points 0, 1000 and 6113 missing)."""
    def case():
        h = ec.codes_grib_new_from_samples(f"reduced_gg_pl_grib{edition}")
        set_keys(h, {"centre": "ecmf", "dataDate": DATE, "dataTime": TIME})
        return [(h, fill(h, temperature, missing=[0, 1000, 6113] if edition == 2 else ()))]
    return case


def filled_rows(m, pl):
    """A reduced grid's values on the regular grid of max(pl) longitudes per row, as cdo's
    setgridtype,regular makes it: linear in longitude between a row's two nearest points, around
    the circle (numpy's periodic interp), missing next to a missing point."""
    values = np.array([np.nan if v is None else v for v in m["values"]])
    lats = np.array(m["latitudes"])
    ni = int(max(pl))
    out_v, out_la, out_lo = [], [], []
    start = 0
    for n in pl:
        n = int(n)
        row, src = values[start:start + n], np.arange(n) * 360.0 / n
        lat = lats[start]
        start += n
        dst = np.arange(ni) * 360.0 / ni
        filled = np.interp(dst, src, np.nan_to_num(row), period=360.0)
        holes = np.interp(dst, src, np.isnan(row).astype(float), period=360.0) > 0
        filled[holes] = np.nan
        out_v += [None if np.isnan(v) else float(v) for v in filled]
        out_la += [float(lat)] * ni
        out_lo += [float(v) for v in dst]
    return {"Ni": ni, "values": out_v, "latitudes": out_la, "longitudes": out_lo}


# -- model levels --------------------------------------------------------------------------------

# An IFS-like set of 7 half levels (6 model levels): A in Pa, B dimensionless, top to bottom.
HALF_A = [0.0, 2000.0, 8000.0, 15000.0, 12000.0, 4000.0, 0.0]
HALF_B = [0.0, 0.0, 0.02, 0.15, 0.45, 0.8, 1.0]


def surface_pressure(lats, lons):
    """Between 950 and 1030 hPa across the grid (Pa)."""
    return 99000.0 + 4000.0 * np.sin(np.radians(lons) * 6.0) * np.cos(np.radians(lats) * 4.0)


def model_levels_case(edition):
    """t on the 6 model levels (typeOfLevel hybrid, PV array of the 7 half levels' A and B) and
    the surface pressure: GRIB2 as ECMWF writes it, ln(ps) (`lnsp`) on model level 1; GRIB1 as
    most centres do, `sp` on the surface. t is a function of each level's pressure and position, so it
    varies along every column."""
    def case():
        sample = "regular_ll_pl_grib2" if edition == 2 else "regular_ll_pl_grib1"
        out = []
        ps = None
        for level in range(1, 7):
            h = grib2(sample) if edition == 2 else grib1(sample, "t", 850, 0, REGULAR_LL)
            set_keys(h, REGULAR_LL)
            set_keys(h, {"typeOfLevel": "hybrid", "level": level, "shortName": "t"})
            ec.codes_set_long(h, "PVPresent", 1)
            ec.codes_set_array(h, "pv", HALF_A + HALF_B)
            lats, lons = coordinates(h)
            ps = surface_pressure(lats, lons)
            p = 0.5 * (HALF_A[level - 1] + HALF_A[level]) + 0.5 * (HALF_B[level - 1] + HALF_B[level]) * ps
            out.append((h, fill(h, lambda la, lo, p=p: 288.0 * (p / 1e5) ** 0.19 + 0.05 * lo - 0.03 * la)))
        if edition == 2:
            h = grib2(sample)
            set_keys(h, REGULAR_LL)
            set_keys(h, {"typeOfLevel": "hybrid", "level": 1, "shortName": "lnsp"})
            out.append((h, fill(h, lambda la, lo: np.log(surface_pressure(la, lo)))))
        else:
            h = grib1(sample, "t", 850, 0, REGULAR_LL)
            set_keys(h, {"typeOfLevel": "surface", "level": 0, "shortName": "sp"})
            out.append((h, fill(h, surface_pressure)))
        return out
    return case


def model_level_reference(path, target_hpa):
    """t at `target_hpa` from the file as ecCodes reads it back: each model level's pressure
    0.5 (A[k-1] + A[k]) + 0.5 (B[k-1] + B[k]) ps from the PV array ecCodes reads and the decoded
    surface pressure (e^lnsp or sp), then linear in ln p between the two levels that bracket the
    target in each column, as NCL's vinth2p (intyp 2); null where no two levels bracket it."""
    t, ps, pv = {}, None, None
    with open(path, "rb") as f:
        while (h := ec.codes_grib_new_from_file(f)) is not None:
            name, values = ec.codes_get(h, "shortName"), ec.codes_get_values(h)
            if name == "t":
                t[ec.codes_get(h, "level")] = values
                pv = ec.codes_get_array(h, "pv")
            elif name == "lnsp":
                ps = np.exp(values)
            else:
                ps = values
            ec.codes_release(h)
    a, b = pv[: len(pv) // 2], pv[len(pv) // 2:]
    levels = sorted(t)
    lnp = np.array([np.log(0.5 * (a[k - 1] + a[k]) + 0.5 * (b[k - 1] + b[k]) * ps) for k in levels])
    field = np.array([t[k] for k in levels])
    target = np.log(target_hpa * 100.0)
    out = []
    for c in range(field.shape[1]):
        got = None
        for k in range(len(levels) - 1):
            lo, hi = lnp[k, c], lnp[k + 1, c]
            if min(lo, hi) <= target <= max(lo, hi):
                w = (target - lo) / (hi - lo)
                got = float(field[k, c] + w * (field[k + 1, c] - field[k, c]))
                break
        out.append(got)
    return out


CASES = [(p + ".grib2", lambda p=p: packing_case(p)) for p in PACKINGS] + [
    ("grid_simple_bitmap.grib2", bitmap_case),
    ("regular_gg.grib2", regular_gg_case),
    ("rotated_ll.grib2", rotated_ll_case),
    ("lambert.grib2", lambert_case),
    ("polar_stereographic.grib2", polar_stereographic_case),
    ("mercator.grib2", mercator_case),
    ("forecast.grib2", forecast_case),
    ("ensemble.grib2", ensemble_case),
    ("grib1_regular_ll.grib1", grib1_regular_ll_case),
    ("grib1_gaussian.grib1", grib1_gaussian_case),
    ("grib1_multi.grib1", grib1_multi_case),
    ("grib1_lambert.grib1", grib1_lambert_case),
    ("grib1_polar_stereographic.grib1", grib1_polar_case),
    ("grib1_south_polar_stereographic.grib1", grib1_south_polar_case),
    ("grib1_mercator.grib1", grib1_mercator_case),
    ("reduced_gg.grib1", reduced_case(1)),
    ("reduced_gg.grib2", reduced_case(2)),
    ("model_levels.grib2", model_levels_case(2)),
    ("model_levels.grib1", model_levels_case(1)),
]

# The model-level files and the pressures (hPa) of their reference.
MODEL_LEVEL_TARGETS = {"model_levels.grib2": [500.0, 250.0], "model_levels.grib1": [500.0]}


# -- reading back --------------------------------------------------------------------------------


def get(h, key, kind=None):
    if not ec.codes_is_defined(h, key):
        return None
    if kind is not None:
        return ec.codes_get(h, key, kind)
    return ec.codes_get(h, key)


# Code numbers reported in each message: the key's integer where the message is of one of these
# editions and ecCodes defines the key, else null. (ecCodes also answers some GRIB2 names for
# GRIB1 messages, such as productDefinitionTemplateNumber, from its own concepts: left out.)
CODE_KEYS = {
    "paramId": (1, 2),
    "localDefinitionNumber": (1, 2),
    "discipline": (2,),
    "parameterCategory": (2,),
    "parameterNumber": (2,),
    "typeOfFirstFixedSurface": (2,),
    "gridDefinitionTemplateNumber": (2,),
    "productDefinitionTemplateNumber": (2,),
    "dataRepresentationTemplateNumber": (2,),
    "typeOfEnsembleForecast": (2,),
    "numberOfForecastsInEnsemble": (2,),
    "table2Version": (1,),
    "indicatorOfParameter": (1,),
    "indicatorOfTypeOfLevel": (1,),
    "dataRepresentationType": (1,),
}


def describe(h, name, index):
    """What ecCodes reads from one message, as one entry of reference.json."""
    grid_type = ec.codes_get(h, "gridType")
    projected = grid_type in ("lambert", "polar_stereographic")
    bitmap = bool(ec.codes_get(h, "bitmapPresent"))
    missing_value = float(ec.codes_get_double(h, "missingValue"))
    values = ec.codes_get_values(h)
    e, d = ec.codes_get(h, "binaryScaleFactor"), ec.codes_get(h, "decimalScaleFactor")
    edition = ec.codes_get(h, "edition")
    grid = {}
    for key in GRID_KEYS[grid_type]:
        value = get(h, key)
        if value is not None:
            grid[key] = value
    codes = {key: get(h, key, int) if edition in editions else None for key, editions in CODE_KEYS.items()}
    extra = {}
    if grid_type == "reduced_gg":
        extra["pl"] = [int(n) for n in ec.codes_get_array(h, "pl")]
    return extra | {
        "file": name,
        "message": index,
        "edition": edition,
        "shortName": ec.codes_get(h, "shortName"),
        "name": ec.codes_get(h, "name"),
        "units": ec.codes_get(h, "units"),
        "typeOfLevel": ec.codes_get(h, "typeOfLevel"),
        "level": ec.codes_get(h, "level"),
        "stepRange": ec.codes_get(h, "stepRange", str),
        "step": ec.codes_get(h, "step", int),
        "dataDate": ec.codes_get(h, "dataDate"),
        "dataTime": ec.codes_get(h, "dataTime"),
        "validityDate": ec.codes_get(h, "validityDate"),
        "validityTime": ec.codes_get(h, "validityTime"),
        "perturbationNumber": get(h, "perturbationNumber", int),
        "gridType": grid_type,
        "packingType": ec.codes_get(h, "packingType"),
        "Ni": ec.codes_get(h, "Nx" if projected else "Ni"),
        "Nj": ec.codes_get(h, "Ny" if projected else "Nj"),
        "numberOfValues": ec.codes_get(h, "numberOfValues"),
        "numberOfMissing": ec.codes_get(h, "numberOfMissing"),
        "bitmapPresent": bitmap,
        "missingValue": missing_value,
        "bitsPerValue": ec.codes_get(h, "bitsPerValue"),
        "binaryScaleFactor": e,
        "decimalScaleFactor": d,
        "referenceValue": float(ec.codes_get_double(h, "referenceValue")),
        "precision": math.ldexp(1.0, e) / 10.0**d / 2.0,
        "numberOfDataPoints": ec.codes_get(h, "numberOfDataPoints"),
        **codes,
        "grid": grid,
        "values": [None if bitmap and v == missing_value else float(v) for v in values],
        "latitudes": [float(v) for v in ec.codes_get_array(h, "latitudes")],
        "longitudes": [float(v) for v in ec.codes_get_array(h, "longitudes")],
    }


def read_file(path):
    messages = []
    with open(path, "rb") as f:
        while True:
            h = ec.codes_grib_new_from_file(f)
            if h is None:
                break
            m = describe(h, os.path.basename(path), len(messages))
            if "pl" in m:
                m["regular"] = filled_rows(m, m["pl"])
            if os.path.basename(path).startswith("grib1_south_polar"):
                m["eccodes_latitudes"], m["eccodes_longitudes"] = m["latitudes"], m["longitudes"]
                m["latitudes"], m["longitudes"] = south_polar_positions()
            messages.append(m)
            ec.codes_release(h)
    return messages


def main(out):
    os.makedirs(out, exist_ok=True)
    files, rows, failures = [], [], []
    for name, case in CASES:
        path = os.path.join(out, name)
        written = []
        with open(path, "wb") as f:
            for h, values in case():
                ec.codes_write(h, f)
                ec.codes_release(h)
                written.append(values)
        messages = read_file(path)
        if len(messages) != len(written):
            failures.append(f"{name}: {len(messages)} messages read, {len(written)} written")
        if not messages:
            continue
        worst = 0.0
        for m, want in zip(messages, written):
            got = np.array([np.nan if v is None else v for v in m["values"]])
            if got.shape != want.shape or not np.array_equal(np.isnan(got), np.isnan(want)):
                failures.append(f"{name}[{m['message']}]: missing points differ")
                continue
            err = float(np.nanmax(np.abs(got - want)))
            worst = max(worst, err / m["precision"])
            if err > m["precision"] * (1 + 1e-6):
                failures.append(f"{name}[{m['message']}]: error {err} > precision {m['precision']}")
            lats, lons = np.array(m["latitudes"]), np.array(m["longitudes"])
            if lats.shape != got.shape or lons.shape != got.shape:
                failures.append(f"{name}[{m['message']}]: {lats.size} latitudes, {lons.size} longitudes")
            elif not (np.all(np.abs(lats) <= 90) and np.all(np.abs(lons) <= 360)):
                failures.append(f"{name}[{m['message']}]: coordinates out of range")
        files.append({"file": name, "edition": messages[0]["edition"], "count": len(messages), "messages": messages})
        first = messages[0]
        rows.append((name, len(messages), first["gridType"], first["packingType"], first["Ni"], first["Nj"],
                     sum(m["numberOfMissing"] for m in messages), worst, os.path.getsize(path)))
    reference = {
        "eccodes": {"library": ec.codes_get_api_version(), "python": ec.bindings_version},
        "files": files,
        "model_levels": {
            name: {f"{p:g}": model_level_reference(os.path.join(out, name), p) for p in targets}
            for name, targets in MODEL_LEVEL_TARGETS.items()
        },
    }
    with open(os.path.join(out, "reference.json"), "w") as f:
        json.dump(reference, f, separators=(",", ":"))
        f.write("\n")
    print(f"{'file':42} {'msgs':>4} {'gridType':20} {'packingType':34} {'Ni':>3} {'Nj':>3} {'miss':>4} "
          f"{'err/prec':>8} {'bytes':>6}")
    for name, n, grid_type, packing, ni, nj, miss, worst, size in rows:
        print(f"{name:42} {n:4} {grid_type:20} {packing:34} {ni:3} {nj:3} {miss:4} {worst:8.3f} {size:6}")
    for failure in failures:
        print("FAIL", failure, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
