//! Valid files other tools write that the readers must take: HDF5 LZ4 chunks of several blocks
//! (h5py with hdf5plugin), each checked value for value against what the writing tool reads back
//! (tests/python/write_reader_cases.py).

use crate::common::{python_reference, reference_numbers};
use hdrvis::datasets::load_volume_var;

/// LZ4 chunks cut into blocks smaller than the chunk (compressed blocks, raw blocks, a short last
/// block) and one block per chunk all read as h5py reads them.
#[test]
fn hdf5_lz4_blocks_smaller_than_the_chunk_read_like_h5py() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = python_reference("write_reader_cases.py", dir.path(), "hdf5_lz4") else {
        return;
    };
    let file = dir.path().join("lz4.h5");
    for name in ["smooth", "noise", "counts"] {
        let v = load_volume_var(&file, Some(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(v.dims, [16, 8, 4], "{name}");
        let expect: Vec<f32> = reference_numbers(&r, name)
            .iter()
            .map(|&x| x as f32)
            .collect();
        assert_eq!(v.data, expect, "{name}");
    }
}
