//! Keyword-only arguments read by name from a call's `**kwargs`.
//!
//! `render`, `build` and `sample_sdf` take many keyword-only options. Declared one parameter
//! each, their Rust functions took 9 to 11 arguments; read from the keywords dict into one
//! options struct per call, each function takes its positional arguments and that struct. The
//! Python signatures are unchanged (`text_signature` states them for `help()` and
//! `inspect.signature`, the stubs in `python/sdfmo/_sdfmo.pyi` type them), and so are the
//! errors a caller sees: an unknown keyword is Python's `TypeError: f() got an unexpected
//! keyword argument 'x'`, a value of the wrong type a `TypeError` naming the argument.

use pyo3::conversion::FromPyObjectOwned;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The keywords of one call, taken one by one; [`Kwargs::finish`] refuses any left over.
pub struct Kwargs<'py> {
    function: &'static str,
    dict: Option<Bound<'py, PyDict>>,
}

impl<'py> Kwargs<'py> {
    /// The keywords `dict` (PyO3 passes `None` when there are none) of a call of `function`.
    pub fn new(function: &'static str, dict: Option<&Bound<'py, PyDict>>) -> Kwargs<'py> {
        Kwargs {
            function,
            dict: dict.cloned(),
        }
    }

    /// The value of keyword `name`, or `default` when it was not given. The dict is PyO3's own
    /// copy for this call, so taking an entry out of it changes nothing the caller holds.
    ///
    /// # Errors
    /// `TypeError` naming the argument when the value does not convert to `T`; other
    /// conversion errors (an `OverflowError`) as they are.
    pub fn take<T: FromPyObjectOwned<'py>>(&mut self, name: &str, default: T) -> PyResult<T> {
        let Some(dict) = &self.dict else {
            return Ok(default);
        };
        let Some(value) = dict.get_item(name)? else {
            return Ok(default);
        };
        dict.del_item(name)?;
        value.extract::<T>().map_err(|e| {
            let e: PyErr = e.into();
            let py = value.py();
            if e.is_instance_of::<PyTypeError>(py) {
                PyTypeError::new_err(format!("argument '{name}': {}", e.value(py)))
            } else {
                e
            }
        })
    }

    /// Checks that every keyword was taken.
    ///
    /// # Errors
    /// `TypeError: f() got an unexpected keyword argument 'x'`, as Python says it.
    pub fn finish(self) -> PyResult<()> {
        let Some(dict) = self.dict else {
            return Ok(());
        };
        match dict.keys().iter().next() {
            None => Ok(()),
            Some(key) => Err(PyTypeError::new_err(format!(
                "{}() got an unexpected keyword argument '{}'",
                self.function,
                key.str()?
            ))),
        }
    }
}
