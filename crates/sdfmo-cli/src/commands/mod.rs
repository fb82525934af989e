//! One module per command, plus what several of them share.

pub mod build;
pub mod compare;
pub mod distance;
pub mod generate;
pub mod info;
pub mod render;
pub mod sweep;

use sdf_multioctree::build::Method;
use sdf_multioctree::distance::SignMode;
use sdf_multioctree::format::ValueBits;
pub use sdfmo_harness::input::{load_input, InputMesh};
/// The pool of a command's `--threads` (the libraries run on the caller's pool).
pub use sdfmo_harness::Workers;

use crate::args::{BitsArg, MethodArg, SignArg};

impl SignArg {
    /// The distance layer's sign mode.
    pub fn mode(self) -> SignMode {
        match self {
            SignArg::Auto => SignMode::Auto,
            SignArg::Pseudonormal => SignMode::PseudoNormal,
            SignArg::Winding => SignMode::Winding,
        }
    }
}

/// Name of a resolved sign mode, as the `--sign` flag spells it.
pub fn sign_name(mode: SignMode) -> &'static str {
    match mode {
        SignMode::Auto => "auto",
        SignMode::PseudoNormal => "pseudonormal",
        SignMode::Winding => "winding",
    }
}

impl MethodArg {
    /// The builder's method.
    pub fn method(self, max_voxels: u8) -> Method {
        match self {
            MethodArg::Svo => Method::Svo,
            MethodArg::Multi => Method::Multi { max_voxels },
        }
    }
}

impl BitsArg {
    /// The format's value bits.
    pub fn bits(self) -> ValueBits {
        match self {
            BitsArg::Eight => ValueBits::Eight,
            BitsArg::Sixteen => ValueBits::Sixteen,
        }
    }

    /// Bits as a number.
    pub fn count(self) -> u32 {
        match self {
            BitsArg::Eight => 8,
            BitsArg::Sixteen => 16,
        }
    }
}

/// The memory budget of a build: `--max-memory`, else the builder's default (half the
/// physical memory).
pub fn memory_budget(max_memory: Option<u64>) -> Option<u64> {
    max_memory.or_else(sdf_multioctree::build::default_memory_budget)
}
