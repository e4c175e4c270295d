//! GeoTIFF rasters (`.tif`, `.tiff`), decoded by the pure-Rust `tiff` crate (strips or tiles,
//! uncompressed, deflate or LZW, 8- to 64-bit integer and float samples) and placed on the Earth
//! by the GeoTIFF tags: ModelPixelScale with ModelTiepoint, or a ModelTransformation without
//! rotation or shear (a rotated raster is refused: it is no regular lon/lat grid). The CRS comes
//! from the GeoKeyDirectory and must be geographic WGS 84 (EPSG:4326, or a user-defined
//! geographic CRS on the WGS 84 datum); a projected CRS is refused in one line naming its EPSG
//! code, since a projected raster is curvilinear in longitude and latitude and would have to be
//! resampled, which a reader should not do behind the user's back (`gdalwarp -t_srs EPSG:4326`
//! does it with the user's choice of resampling). GTRasterType decides where a pixel's
//! coordinates are: PixelIsArea (the default) puts the tiepoint at a pixel's corner, PixelIsPoint
//! at its centre; the grid's nodes are always pixel centres. GDAL's nodata tag (42113) marks
//! missing values (in stored units); GDAL's metadata tag (42112) gives a band's scale, offset
//! and unit (values = stored × scale + offset, as GDAL's `-unscale` and rasterio's
//! `scales`/`offsets` mean them). Rows keep their storage order here; the grid built from them runs in
//! increasing latitude, so a map shows north up whatever the sign of the y scale.

use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

use super::scalar::Scalar;
use crate::error::{Error, Result};

/// GeoKey ids (GeoTIFF 1.1, section 7) and the values hdrvis takes from them.
const GT_MODEL_TYPE: u16 = 1024;
const GT_RASTER_TYPE: u16 = 1025;
const GEOGRAPHIC_TYPE: u16 = 2048;
const GEOG_GEODETIC_DATUM: u16 = 2050;
const GEOG_ANGULAR_UNITS: u16 = 2054;
const PROJECTED_CS_TYPE: u16 = 3072;
const MODEL_PROJECTED: u16 = 1;
const MODEL_GEOGRAPHIC: u16 = 2;
const RASTER_PIXEL_IS_POINT: u16 = 2;
const USER_DEFINED: u16 = 32767;
const EPSG_WGS84: u16 = 4326;
const DATUM_WGS84: u16 = 6326;
const ANGULAR_DEGREE: u16 = 9102;

/// One band of a GeoTIFF with the coordinates of its pixel centres, in storage order.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Raster {
    /// The file's stem, with " band N" for a band of a multi-band file.
    pub name: String,
    pub dtype: String,
    /// `[rows, columns]`.
    pub shape: [usize; 2],
    /// Row-major as stored (row 0 first), NaN where the file has its nodata value.
    pub data: Vec<f64>,
    /// Longitude of each column's pixel centres (degrees east).
    pub lon: Vec<f64>,
    /// Latitude of each row's pixel centres (degrees north), as stored: decreasing when the
    /// file is stored north up.
    pub lat: Vec<f64>,
    /// How the georeferencing was read, for `hdrvis info`.
    pub notes: Vec<String>,
    pub fill_count: usize,
    /// The band's unit (GDAL's UNITTYPE), if the file names one.
    pub units: Option<String>,
}

impl Raster {
    /// The band as an array (dimensions y, x), for `hdrvis info` and `read_array`.
    pub(crate) fn array(&self) -> crate::datasets::ArrayData {
        let mut array = crate::datasets::plain_array(
            &self.name,
            self.shape.to_vec(),
            self.dtype.clone(),
            self.data.clone(),
        );
        array.dims = vec!["y".into(), "x".into()];
        array.fill_count = self.fill_count;
        array.units = self.units.clone();
        array
    }

    /// What `hdrvis info` adds: the CRS, how the georeferencing was read, the pixel centres'
    /// extent and the nodata value.
    pub(crate) fn describe(&self) -> Vec<String> {
        let mut lines = self.notes.clone();
        let (lon, lat) = (&self.lon, &self.lat);
        lines.push(format!(
            "pixel centres: lon {} to {}, lat {} to {} (first to last column and row)",
            lon[0],
            lon[lon.len() - 1],
            lat[0],
            lat[lat.len() - 1]
        ));
        lines
    }
}

/// Refuses a variable name: a GeoTIFF has bands, not variables.
pub(crate) fn no_variable(path: &Path, var: Option<&str>) -> Result<()> {
    match var {
        Some(v) => Err(fail(
            path,
            format!("a GeoTIFF has no variables (asked for '{v}'); choose a band with band: N"),
        )),
        None => Ok(()),
    }
}

fn fail(path: &Path, msg: impl Into<String>) -> Error {
    Error::format(path, msg.into())
}

fn tiff_error(path: &Path, e: &tiff::TiffError) -> Error {
    fail(path, format!("not a readable TIFF file: {e}"))
}

/// The decoder's limits: half the memory available, so that a corrupt value count in a tag (which
/// the decoder allocates for before reading) is an error instead of an abort; the image itself
/// is checked against the memory before it is decoded.
fn memory_limits() -> Limits {
    let half = crate::model::volume::available_memory_bytes()
        .map_or(usize::MAX, |b| usize::try_from(b / 2).unwrap_or(usize::MAX));
    let mut limits = Limits::unlimited();
    limits.decoding_buffer_size = half;
    limits.ifd_value_size = half;
    limits.intermediate_buffer_size = half;
    limits
}

/// Reads band `band` (1-based, as GDAL counts; without it the file must have one band).
pub(crate) fn read(path: &Path, band: Option<usize>) -> Result<Raster> {
    crate::io::check_regular_file(path)?;
    let file = std::fs::File::open(path).map_err(|e| fail(path, e.to_string()))?;
    let mut dec = Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| tiff_error(path, &e))?
        .with_limits(memory_limits());
    let (nx, ny) = dec.dimensions().map_err(|e| tiff_error(path, &e))?;
    let (nx, ny) = (nx as usize, ny as usize);
    let samples = usize::from(
        dec.colortype()
            .map_err(|e| tiff_error(path, &e))?
            .num_samples(),
    );
    let band = choose_band(path, band, samples)?;
    let geo = georeferencing(path, &mut dec)?;
    let lon: Vec<f64> = (0..nx).map(|i| geo.x(i as f64 + geo.offset)).collect();
    let lat: Vec<f64> = (0..ny).map(|j| geo.y(j as f64 + geo.offset)).collect();
    if let Some(bad) = lat.iter().find(|v| v.abs() > 90.0) {
        return Err(fail(
            path,
            format!("pixel-centre latitude {bad} is outside [-90, 90]: the georeferencing is not in degrees"),
        ));
    }
    let nodata = nodata(path, &mut dec)?;
    let meta = band_metadata(path, &mut dec, band)?;
    let planar = dec
        .find_tag_unsigned::<u16>(Tag::PlanarConfiguration)
        .map_err(|e| tiff_error(path, &e))?
        == Some(2);
    // At the peak: the decoded samples (up to 8 bytes each), their f64 copies and the band's.
    crate::model::volume::check_allocation(
        (nx as u64 * ny as u64 * samples as u64).saturating_mul(24),
        &format!("{}: {nx}x{ny} pixels, {samples} band(s)", path.display()),
    )?;
    let mut buffer = DecodingResult::U8(Vec::new());
    dec.read_image_to_buffer(&mut buffer)
        .map_err(|e| tiff_error(path, &e))?;
    let (scalar, all) = samples_of(&buffer);
    let pixels = nx * ny;
    if all.len() < pixels * samples {
        return Err(fail(
            path,
            format!(
                "decoded {} samples; {nx}x{ny} pixels of {samples} band(s) need {}",
                all.len(),
                pixels * samples
            ),
        ));
    }
    let pick = |p: usize| {
        if planar {
            all[(band - 1) * pixels + p]
        } else {
            all[p * samples + band - 1]
        }
    };
    let stored_nodata = nodata.map(|v| stored(scalar, v));
    let mut fill_count = 0;
    let data = (0..pixels)
        .map(|p| {
            let v = pick(p);
            let missing = stored_nodata.is_some_and(|n| v == n || (n.is_nan() && v.is_nan()));
            fill_count += usize::from(missing);
            if missing {
                f64::NAN
            } else {
                v * meta.scale + meta.offset
            }
        })
        .collect();
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("raster");
    let mut notes = geo.notes;
    if let Some(n) = nodata {
        notes.push(format!("nodata (GDAL_NODATA): {n}"));
    }
    if meta.scale != 1.0 || meta.offset != 0.0 {
        notes.push(format!(
            "values = stored x {} + {} (GDAL scale and offset, GDAL_METADATA)",
            meta.scale, meta.offset
        ));
    }
    Ok(Raster {
        name: if samples > 1 {
            format!("{stem} band {band}")
        } else {
            stem.to_string()
        },
        dtype: scalar.name().to_string(),
        shape: [ny, nx],
        data,
        lon,
        lat,
        notes,
        fill_count,
        units: meta.units,
    })
}

/// The band to read, 1-based: `band`, else the only one.
fn choose_band(path: &Path, band: Option<usize>, samples: usize) -> Result<usize> {
    match (band, samples) {
        (None, 1) => Ok(1),
        (None, n) => Err(fail(
            path,
            format!("has {n} bands; choose one with band: N (hdrvis info --band N; 1 to {n}, as GDAL counts)"),
        )),
        (Some(b), n) if b < 1 || b > n => Err(fail(
            path,
            format!("band {b} is out of range; the file has {n} band(s), 1 to {n}"),
        )),
        (Some(b), _) => Ok(b),
    }
}

/// The decoded samples as f64 and their stored type.
fn samples_of(buffer: &DecodingResult) -> (Scalar, Vec<f64>) {
    fn all<T: Copy>(v: &[T], f: impl Fn(T) -> f64) -> Vec<f64> {
        v.iter().map(|&x| f(x)).collect()
    }
    match buffer {
        DecodingResult::U8(v) => (Scalar::U8, all(v, f64::from)),
        DecodingResult::U16(v) => (Scalar::U16, all(v, f64::from)),
        DecodingResult::U32(v) => (Scalar::U32, all(v, f64::from)),
        DecodingResult::U64(v) => (Scalar::U64, all(v, |x| x as f64)),
        DecodingResult::I8(v) => (Scalar::I8, all(v, f64::from)),
        DecodingResult::I16(v) => (Scalar::I16, all(v, f64::from)),
        DecodingResult::I32(v) => (Scalar::I32, all(v, f64::from)),
        DecodingResult::I64(v) => (Scalar::I64, all(v, |x| x as f64)),
        DecodingResult::F16(v) => (Scalar::F16, all(v, |x| x.to_f64())),
        DecodingResult::F32(v) => (Scalar::F32, all(v, f64::from)),
        DecodingResult::F64(v) => (Scalar::F64, all(v, |x| x)),
    }
}

/// The nodata value as a sample of type `scalar` holds it, so that a float32 file's
/// "-3.4028234663852886e+38" matches its samples exactly.
fn stored(scalar: Scalar, v: f64) -> f64 {
    match scalar {
        Scalar::F16 => half::f16::from_f64(v).to_f64(),
        Scalar::F32 => f64::from(v as f32),
        _ => v,
    }
}

/// GDAL's nodata tag (ASCII, "nan" allowed), if any.
fn nodata<R: std::io::Read + std::io::Seek>(
    path: &Path,
    dec: &mut Decoder<R>,
) -> Result<Option<f64>> {
    let Some(value) = dec
        .find_tag(Tag::GdalNodata)
        .map_err(|e| tiff_error(path, &e))?
    else {
        return Ok(None);
    };
    let text = value
        .into_string()
        .map_err(|e| fail(path, format!("GDAL_NODATA (tag 42113): {e}")))?;
    let text = text.trim_end_matches('\0').trim();
    text.parse::<f64>().map(Some).map_err(|_| {
        fail(
            path,
            format!("GDAL_NODATA (tag 42113) is '{text}'; expected a number or nan"),
        )
    })
}

/// What GDAL's metadata tag says of one band: value = stored * scale + offset, and its unit.
#[derive(Debug, PartialEq)]
struct BandMetadata {
    scale: f64,
    offset: f64,
    units: Option<String>,
}

/// GDAL's metadata tag (42112, ASCII XML: `<GDALMetadata><Item name="SCALE" sample="0"
/// role="scale">0.01</Item>...`) for band `band` (1-based; the tag's `sample` counts from 0).
/// Scale 1 and offset 0 where the tag or its items are absent; dataset items (no `sample`) are
/// not the band's.
fn band_metadata<R: std::io::Read + std::io::Seek>(
    path: &Path,
    dec: &mut Decoder<R>,
    band: usize,
) -> Result<BandMetadata> {
    let mut meta = BandMetadata {
        scale: 1.0,
        offset: 0.0,
        units: None,
    };
    let Some(value) = dec
        .find_tag(Tag::Unknown(GDAL_METADATA))
        .map_err(|e| tiff_error(path, &e))?
    else {
        return Ok(meta);
    };
    let bad = |msg: String| fail(path, format!("GDAL_METADATA (tag 42112): {msg}"));
    let text = value.into_string().map_err(|e| bad(e.to_string()))?;
    for (role, sample, item) in gdal_items(text.trim_end_matches('\0')).map_err(bad)? {
        if sample != Some(band - 1) {
            continue;
        }
        let number = || {
            item.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    bad(format!(
                        "the {role} of band {band} is '{item}'; expected a finite number"
                    ))
                })
        };
        match role.as_str() {
            "scale" => meta.scale = number()?,
            "offset" => meta.offset = number()?,
            "unittype" if !item.trim().is_empty() => meta.units = Some(item.trim().to_string()),
            _ => {}
        }
    }
    Ok(meta)
}

/// GDAL's metadata tag.
const GDAL_METADATA: u16 = 42112;

/// The `Item`s of GDAL's metadata XML as (role, sample, text); items without a role are
/// dataset or domain metadata and are left out.
fn gdal_items(xml: &str) -> std::result::Result<Vec<(String, Option<usize>, String)>, String> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut items = Vec::new();
    let mut open: Option<(String, Option<usize>)> = None;
    loop {
        let event = reader.read_event().map_err(|e| {
            format!(
                "not valid XML near byte {}: {}",
                reader.error_position(),
                crate::error::excerpt(&e.to_string(), 80)
            )
        })?;
        match event {
            Event::Start(tag) if tag.local_name().as_ref() == "Item" => {
                let attr = |key: &str| -> Option<String> {
                    let a = tag.try_get_attribute(key).ok()??;
                    Some(
                        a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                            .ok()?
                            .into_owned(),
                    )
                };
                open = attr("role").map(|role| {
                    let sample = attr("sample").and_then(|s| s.trim().parse().ok());
                    (role.to_ascii_lowercase(), sample)
                });
            }
            Event::Text(text) => {
                if let Some((role, sample)) = open.take() {
                    let value = String::from_utf8_lossy(text.as_bytes()).into_owned();
                    items.push((role, sample, value));
                }
            }
            Event::End(_) => open = None,
            Event::Eof => return Ok(items),
            _ => {}
        }
    }
}

/// Raster space to model space (x: longitude, y: latitude) along each axis, and where a pixel's
/// centre is in raster space.
struct Georef {
    /// `x = x0 + sx * i`, `y = y0 + sy * j` for raster coordinates (i, j).
    x0: f64,
    sx: f64,
    y0: f64,
    sy: f64,
    /// 0.5 for PixelIsArea (raster (0, 0) is the first pixel's corner), 0 for PixelIsPoint.
    offset: f64,
    notes: Vec<String>,
}

impl Georef {
    fn x(&self, i: f64) -> f64 {
        self.x0 + self.sx * i
    }
    fn y(&self, j: f64) -> f64 {
        self.y0 + self.sy * j
    }
}

fn f64_tag<R: std::io::Read + std::io::Seek>(
    path: &Path,
    dec: &mut Decoder<R>,
    tag: Tag,
    name: &str,
) -> Result<Option<Vec<f64>>> {
    let value = dec.find_tag(tag).map_err(|e| tiff_error(path, &e))?;
    value
        .map(|v| v.into_f64_vec())
        .transpose()
        .map_err(|e| fail(path, format!("{name}: {e}")))
}

/// The affine map of the model tags and the CRS check of the GeoKeys.
fn georeferencing<R: std::io::Read + std::io::Seek>(
    path: &Path,
    dec: &mut Decoder<R>,
) -> Result<Georef> {
    let scale = f64_tag(path, dec, Tag::ModelPixelScaleTag, "ModelPixelScale")?;
    let tie = f64_tag(path, dec, Tag::ModelTiepointTag, "ModelTiepoint")?;
    let matrix = f64_tag(
        path,
        dec,
        Tag::ModelTransformationTag,
        "ModelTransformation",
    )?;
    let (x0, sx, y0, sy, how) = match (matrix, scale, tie) {
        (Some(m), _, _) => {
            if m.len() != 16 {
                return Err(fail(path, format!("ModelTransformation has {} values; expected 16", m.len())));
            }
            if m[1] != 0.0 || m[4] != 0.0 {
                return Err(fail(path, format!(
                    "ModelTransformation rotates or shears the raster (terms {} and {}); only north-up or south-up rasters without rotation are read (gdalwarp can resample it)",
                    m[1], m[4]
                )));
            }
            (m[3], m[0], m[7], m[5], "ModelTransformation")
        }
        (None, Some(s), Some(t)) => {
            if s.len() < 2 || t.len() < 6 {
                return Err(fail(path, format!(
                    "ModelPixelScale has {} values and ModelTiepoint {}; expected at least 2 and 6",
                    s.len(),
                    t.len()
                )));
            }
            // The y scale is positive for the usual north-up raster: y decreases down the rows.
            (t[3] - s[0] * t[0], s[0], t[4] + s[1] * t[1], -s[1], "ModelPixelScale and ModelTiepoint")
        }
        _ => {
            return Err(fail(
                path,
                "has no GeoTIFF georeferencing: expected ModelPixelScale (tag 33550) with ModelTiepoint (tag 33922), or ModelTransformation (tag 34264)",
            ))
        }
    };
    if !(sx.is_finite() && sy.is_finite() && x0.is_finite() && y0.is_finite())
        || sx == 0.0
        || sy == 0.0
    {
        return Err(fail(path, format!("{how} gives pixel size {sx} x {sy} at ({x0}, {y0}); expected finite, non-zero sizes")));
    }
    let keys = geo_keys(path, dec)?;
    let point = keys
        .iter()
        .any(|&(k, v)| k == GT_RASTER_TYPE && v == RASTER_PIXEL_IS_POINT);
    let crs = check_crs(path, &keys)?;
    let notes = vec![
        format!("CRS: {crs}"),
        format!(
            "georeferencing: {how}, {}, pixel {sx} x {} degrees, rows run {}",
            if point { "PixelIsPoint" } else { "PixelIsArea" },
            sy.abs(),
            if sy < 0.0 {
                "north to south (drawn north up)"
            } else {
                "south to north (drawn north up)"
            }
        ),
    ];
    Ok(Georef {
        x0,
        sx,
        y0,
        sy,
        offset: if point { 0.0 } else { 0.5 },
        notes,
    })
}

/// The GeoKeyDirectory's keys whose values are stored in the directory itself (all hdrvis
/// reads are), as (key, value) pairs.
fn geo_keys<R: std::io::Read + std::io::Seek>(
    path: &Path,
    dec: &mut Decoder<R>,
) -> Result<Vec<(u16, u16)>> {
    let dir = dec
        .find_tag(Tag::GeoKeyDirectoryTag)
        .map_err(|e| tiff_error(path, &e))?
        .ok_or_else(|| {
            fail(
                path,
                "has no GeoKeyDirectory (tag 34735), so its CRS is unknown; expected geographic WGS 84 (EPSG:4326)",
            )
        })?
        .into_u16_vec()
        .map_err(|e| fail(path, format!("GeoKeyDirectory: {e}")))?;
    let count = dir.get(3).copied().unwrap_or(0) as usize;
    if dir.len() < 4 + 4 * count {
        return Err(fail(
            path,
            format!(
                "GeoKeyDirectory has {} values; its header announces {count} keys",
                dir.len()
            ),
        ));
    }
    Ok(dir[4..4 + 4 * count]
        .chunks_exact(4)
        .filter(|k| k[1] == 0)
        .map(|k| (k[0], k[3]))
        .collect())
}

/// "EPSG:4326 (WGS 84)" when the keys describe geographic WGS 84 in degrees, else the error
/// naming the CRS found.
fn check_crs(path: &Path, keys: &[(u16, u16)]) -> Result<String> {
    let key = |id: u16| keys.iter().find(|(k, _)| *k == id).map(|&(_, v)| v);
    let expected = "hdrvis reads geographic WGS 84 (EPSG:4326) GeoTIFFs; reproject with gdalwarp -t_srs EPSG:4326";
    let model = key(GT_MODEL_TYPE).or(key(GEOGRAPHIC_TYPE).map(|_| MODEL_GEOGRAPHIC));
    match model {
        Some(MODEL_PROJECTED) => {
            let crs = match key(PROJECTED_CS_TYPE) {
                Some(USER_DEFINED) | None => "a user-defined projected CRS".to_string(),
                Some(code) => format!("projected CRS EPSG:{code}"),
            };
            return Err(fail(path, format!("is in {crs}; {expected}")));
        }
        Some(MODEL_GEOGRAPHIC) => {}
        Some(other) => {
            return Err(fail(
                path,
                format!("GTModelType is {other} (not geographic); {expected}"),
            ));
        }
        None => {
            return Err(fail(
                path,
                format!("GeoKeyDirectory has no GTModelType; {expected}"),
            ))
        }
    }
    if let Some(units) = key(GEOG_ANGULAR_UNITS).filter(|&u| u != ANGULAR_DEGREE) {
        return Err(fail(
            path,
            format!("angular unit EPSG:{units} is not degrees (EPSG:9102); {expected}"),
        ));
    }
    match (key(GEOGRAPHIC_TYPE), key(GEOG_GEODETIC_DATUM)) {
        (Some(EPSG_WGS84), _) => Ok("EPSG:4326 (WGS 84)".to_string()),
        (Some(USER_DEFINED) | None, Some(DATUM_WGS84)) => {
            Ok("geographic, WGS 84 datum (EPSG:6326)".to_string())
        }
        (Some(USER_DEFINED) | None, datum) => Err(fail(
            path,
            format!(
                "is in a user-defined geographic CRS on datum {}; {expected}",
                datum.map_or("(none given)".to_string(), |d| format!("EPSG:{d}"))
            ),
        )),
        (Some(code), _) => Err(fail(
            path,
            format!("is in geographic CRS EPSG:{code}, not WGS 84; {expected}"),
        )),
    }
}

/// The GeoTIFF reader: one band as a 2-D grid on its pixel centres' longitudes and latitudes;
/// no variables, no dimensions to select, no volume.
pub(crate) struct GeoTiffReader;

impl super::Reader for GeoTiffReader {
    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        _rank: Option<usize>,
        _sel: &crate::datasets::select::Selection,
    ) -> Result<crate::datasets::ArrayData> {
        no_variable(path, var)?;
        Ok(read(path, None)?.array())
    }

    fn volume(
        &self,
        path: &Path,
        _opts: &crate::datasets::LoadOptions,
    ) -> Result<crate::model::Volume> {
        Err(Error::format(
            path,
            "is a GeoTIFF, a 2-D raster; load it with load_grid",
        ))
    }

    /// Band `band` (counted from 1) as a grid file; a variable or selection is refused.
    fn grid(
        &self,
        path: &Path,
        var: Option<&str>,
        sel: &crate::datasets::select::Selection,
        band: Option<usize>,
        resolution: Option<f64>,
    ) -> Result<crate::datasets::GridFile> {
        use crate::model::CoordKind;
        crate::datasets::no_resolution(path, resolution)?;
        no_variable(path, var)?;
        if !sel.is_empty() {
            return Err(Error::format(
                path,
                "selecting by dimension (index, at) needs a NetCDF file or a MintPy time series; a GeoTIFF's bands are chosen with band: N",
            ));
        }
        let r = read(path, band)?;
        let axis = crate::datasets::geographic_axis;
        Ok(crate::datasets::GridFile {
            name: r.name,
            selected: Vec::new(),
            units: r.units,
            shape: r.shape,
            data: r.data,
            x: axis("lon", r.lon, CoordKind::Longitude),
            y: axis("lat", r.lat, CoordKind::Latitude),
            wavelength: None,
            rotated_pole: None,
            regridded: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::encoder::{colortype, TiffEncoder};

    /// A 3x2 float32 GeoTIFF with the given georeferencing tags, GeoKeys and nodata text.
    fn write(path: &Path, scale: &[f64], tie: &[f64], keys: &[u16], nodata: Option<&str>) {
        let file = std::fs::File::create(path).unwrap();
        let mut enc = TiffEncoder::new(file).unwrap();
        let mut image = enc.new_image::<colortype::Gray32Float>(3, 2).unwrap();
        let dir = image.encoder();
        dir.write_tag(Tag::ModelPixelScaleTag, scale).unwrap();
        dir.write_tag(Tag::ModelTiepointTag, tie).unwrap();
        let mut directory = vec![1, 1, 0, (keys.len() / 2) as u16];
        for k in keys.chunks(2) {
            directory.extend([k[0], 0, 1, k[1]]);
        }
        dir.write_tag(Tag::GeoKeyDirectoryTag, &directory[..])
            .unwrap();
        if let Some(n) = nodata {
            dir.write_tag(Tag::GdalNodata, n).unwrap();
        }
        image
            .write_data(&[1.0, f32::NAN, 3.0, 4.0, 5.0, 6.0])
            .unwrap();
    }

    #[test]
    fn a_negative_y_scale_runs_rows_south_to_north_and_user_defined_wgs84_is_accepted() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.tif");
        // Tiepoint at raster (1, 0) = (10.5, -20); y scale -0.5: rows go north.
        let keys = [
            GT_MODEL_TYPE,
            MODEL_GEOGRAPHIC,
            GEOGRAPHIC_TYPE,
            USER_DEFINED,
            GEOG_GEODETIC_DATUM,
            DATUM_WGS84,
        ];
        write(
            &path,
            &[0.5, -0.5, 0.0],
            &[1.0, 0.0, 0.0, 10.5, -20.0, 0.0],
            &keys,
            Some("nan"),
        );
        let r = read(&path, None).unwrap();
        assert_eq!(r.lon, vec![10.25, 10.75, 11.25]);
        assert_eq!(r.lat, vec![-19.75, -19.25]);
        assert_eq!(r.fill_count, 1);
        assert!(r.data[1].is_nan() && r.data[5] == 6.0);
        assert!(r.notes[0].contains("WGS 84 datum"), "{:?}", r.notes);
    }

    #[test]
    fn other_crss_and_bad_tags_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.tif");
        let cases: [(&[u16], Option<&str>, &str); 4] = [
            (
                &[GT_MODEL_TYPE, MODEL_GEOGRAPHIC, GEOGRAPHIC_TYPE, 4269],
                None,
                "geographic CRS EPSG:4269, not WGS 84",
            ),
            (
                &[
                    GT_MODEL_TYPE,
                    MODEL_PROJECTED,
                    PROJECTED_CS_TYPE,
                    USER_DEFINED,
                ],
                None,
                "a user-defined projected CRS",
            ),
            (
                &[
                    GT_MODEL_TYPE,
                    MODEL_GEOGRAPHIC,
                    GEOGRAPHIC_TYPE,
                    EPSG_WGS84,
                    GEOG_ANGULAR_UNITS,
                    9101,
                ],
                None,
                "EPSG:9101 is not degrees",
            ),
            (
                &[GT_MODEL_TYPE, MODEL_GEOGRAPHIC, GEOGRAPHIC_TYPE, EPSG_WGS84],
                Some("none"),
                "GDAL_NODATA (tag 42113) is 'none'",
            ),
        ];
        // A plain TIFF: no georeferencing at all.
        let file = std::fs::File::create(&path).unwrap();
        let mut enc = TiffEncoder::new(file).unwrap();
        enc.write_image::<colortype::Gray8>(2, 1, &[1, 2]).unwrap();
        let e = read(&path, None).unwrap_err().to_string();
        assert!(e.contains("has no GeoTIFF georeferencing"), "{e}");
        for (keys, nodata, want) in cases {
            write(
                &path,
                &[1.0, 1.0, 0.0],
                &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                keys,
                nodata,
            );
            let e = read(&path, None).unwrap_err().to_string();
            assert!(e.contains(want) && !e.contains('\n'), "{want}: {e}");
        }
    }

    #[test]
    fn gdal_metadata_items_are_read_by_role_and_band() {
        let xml = r#"<GDALMetadata>
  <Item name="AREA_OR_POINT">Area</Item>
  <Item name="OFFSET" sample="0" role="offset">-5</Item>
  <Item name="SCALE" sample="0" role="scale">0.01</Item>
  <Item name="SCALE" sample="1" role="scale">2</Item>
  <Item name="UNITTYPE" sample="1" role="unittype">mm</Item>
</GDALMetadata>"#;
        let items = gdal_items(xml).unwrap();
        assert_eq!(
            items,
            vec![
                ("offset".to_string(), Some(0), "-5".to_string()),
                ("scale".to_string(), Some(0), "0.01".to_string()),
                ("scale".to_string(), Some(1), "2".to_string()),
                ("unittype".to_string(), Some(1), "mm".to_string()),
            ]
        );
        let e = gdal_items("<GDALMetadata><Item role=\"scale\">1</Itm>").unwrap_err();
        assert!(e.starts_with("not valid XML") && !e.contains('\n'), "{e}");
    }
}
