//! `.npy` files (NumPy's array format, version 1.0) for readers that do not parse CSV:
//! `numpy.load("dth_trajectory.npy")` gives the array, rows as in the CSV of the same name.
//!
//! Written here rather than through a crate: the one array kind written (a 2-D C-ordered
//! array of little-endian `f64`) is a 10-byte preamble, a Python dict literal padded to 64
//! bytes, and the values; `npyz` and `ndarray-npy` would add a header parser (and `ndarray`)
//! to the build for that.

use std::path::Path;

use super::write_file;
use crate::error::Error;

/// The preamble and header total a multiple of this many bytes (NumPy aligns the data so).
const ALIGN: usize = 64;

/// The bytes of a `.npy` file of the `rows x columns` array `values` (row-major).
///
/// # Panics
/// Never for `values.len() == rows * columns` (the callers build it so); a mismatch would
/// write a file NumPy refuses, so it is checked in debug builds.
pub fn encode(rows: usize, columns: usize, values: &[f64]) -> Vec<u8> {
    debug_assert_eq!(values.len(), rows * columns);
    let mut header =
        format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, {columns}), }}");
    // Magic (6), version (2), header length (2), header, padded with spaces, ending in '\n'.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((ALIGN - unpadded % ALIGN) % ALIGN));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + 8 * values.len());
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    // The header is under 200 bytes: its length fits the format's u16.
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes
}

/// Writes the `rows x columns` array `values` (row-major) to `path` as `.npy`.
pub fn write(path: &Path, rows: usize, columns: usize, values: &[f64]) -> Result<(), Error> {
    write_file(path, encode(rows, columns, values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_is_aligned_and_the_values_follow_it() {
        let bytes = encode(2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, f64::NAN]);
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let len = usize::from(u16::from_le_bytes([bytes[8], bytes[9]]));
        assert_eq!((10 + len) % ALIGN, 0);
        let header = std::str::from_utf8(&bytes[10..10 + len]).unwrap_or_default();
        assert!(header.starts_with("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }"));
        assert!(header.ends_with('\n'));
        let data = &bytes[10 + len..];
        assert_eq!(data.len(), 6 * 8);
        let value = |i: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&data[8 * i..8 * i + 8]);
            f64::from_le_bytes(b)
        };
        assert_eq!((value(0), value(4)), (1.0, 5.0));
        assert!(value(5).is_nan());
    }
}
