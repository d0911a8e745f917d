//! Every file of a folder with its bytes: the CLI tests' and the MPI test's (`dth-mpi`)
//! byte-for-byte comparisons of outputs.

use std::collections::BTreeMap;
use std::path::Path;

/// Every file of a folder (not recursive), by name, with its bytes.
pub fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}
