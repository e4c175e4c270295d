//! OpenEXR images in the registry: `hdrvis info` and the terminal viewer read them (through
//! `io::exr`), but they hold a picture, not data, so the array and volume readers refuse them in
//! one line that says where they go instead.

use std::path::Path;

use crate::datasets::select::Selection;
use crate::datasets::ArrayData;
use crate::error::{Error, Result};

pub(crate) struct ExrReader;

impl super::Reader for ExrReader {
    fn read(
        &self,
        path: &Path,
        _var: Option<&str>,
        _rank: Option<usize>,
        _sel: &Selection,
    ) -> Result<ArrayData> {
        Err(Error::format(
            path,
            "is an OpenEXR image, not an array of data (hdrvis info describes its channels; hdrvis tui views it)",
        ))
    }
}
