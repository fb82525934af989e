//! Fuzzes the OBJ loader (one validating pass, `src/load/obj.rs`): any bytes must give a `MeshError` or a valid mesh, never a panic, an
//! out-of-bounds read or an allocation sized by an unchecked count.
//!
//! Properties checked on every accepted input: the mesh satisfies `TriMesh::new`'s
//! invariants; cleaning it again changes nothing (welding and cleaning are idempotent); its
//! topology is consistent; and written as binary STL and read back it gives the same triangles.
#![no_main]

mod mesh_common;

use libfuzzer_sys::fuzz_target;
use mesh_common::{check, LIMITS};
use sdfmo_mesh::{load_mesh_from_bytes_with_limits, MeshFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(l) = load_mesh_from_bytes_with_limits(data, "fuzz.obj", Some(MeshFormat::Obj), &LIMITS) {
        check(&l.mesh);
    }
});
