//! One declaration for a struct the host writes and the WGSL reads: [`shared_struct!`] makes the
//! `#[repr(C)]` Rust struct and its WGSL twin (the same members in the same order, the same doc
//! comments) from one list of fields, so the layout cannot be kept in two places. A test reflects
//! the generated WGSL with naga and compares every member's offset with `offset_of!`.

/// The WGSL spelling of a field type of a [`shared_struct!`].
pub(crate) trait WgslType {
    /// The WGSL type.
    const WGSL: &'static str;
}

impl WgslType for f32 {
    const WGSL: &'static str = "f32";
}

impl WgslType for u32 {
    const WGSL: &'static str = "u32";
}

impl WgslType for [f32; 3] {
    const WGSL: &'static str = "vec3<f32>";
}

/// `struct $name as "$Wgsl" { fields }`: the Rust struct `$name` (`Pod`, `#[repr(C)]`) and
/// `$name::wgsl()`, the WGSL declaration `struct $Wgsl { ... }` with the same members, types
/// spelled by [`WgslType`], and the same doc comments. Each field's alignment in WGSL must be
/// its offset's (a `vec3<f32>` on a 16-byte boundary): the layout test checks it.
macro_rules! shared_struct {
    (
        $(#[doc = $doc:literal])*
        struct $name:ident as $wgsl:literal {
            $( $(#[doc = $field_doc:literal])* $field:ident: $ty:ty, )*
        }
    ) => {
        $(#[doc = $doc])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
        struct $name {
            $( $(#[doc = $field_doc])* $field: $ty, )*
        }

        impl $name {
            /// The WGSL declaration of this struct (generated: see `shared_struct!`).
            fn wgsl() -> String {
                let mut s = String::new();
                $( s.push_str(concat!("///", $doc, "\n")); )*
                s.push_str(concat!("struct ", $wgsl, " {\n"));
                $(
                    $( s.push_str(concat!("    ///", $field_doc, "\n")); )*
                    s.push_str(&format!(
                        "    {}: {},\n",
                        stringify!($field),
                        <$ty as $crate::shared_struct::WgslType>::WGSL
                    ));
                )*
                s.push_str("}\n");
                s
            }

            /// Each member's name and byte offset, in order (the layout test compares them
            /// with naga's layout of [`wgsl`](Self::wgsl)).
            #[cfg(test)]
            fn offsets() -> Vec<(&'static str, usize)> {
                vec![$( (stringify!($field), std::mem::offset_of!($name, $field)), )*]
            }
        }
    };
}

pub(crate) use shared_struct;
