//! The worker pool of a front-end's `--threads`: the libraries (builder, renderer, protocol)
//! run on the caller's rayon pool, and the front-ends (the sweep, the CLI's commands) own it.

use crate::{HarnessError, Result};

/// The workers of a `--threads N`: a pool of that many, or rayon's global pool (one per core)
/// without the flag. The outputs do not depend on the count.
#[derive(Debug)]
pub struct Workers(Option<rayon::ThreadPool>);

impl Workers {
    /// A pool of `threads` workers, none for `None`. `Some(0)` is one worker per core, as
    /// rayon counts (the CLI's parser refuses 0 before).
    ///
    /// # Errors
    /// [`HarnessError::Threads`] when the operating system refuses the threads.
    pub fn new(threads: Option<usize>) -> Result<Workers> {
        let Some(n) = threads else {
            return Ok(Workers(None));
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|source| HarnessError::Threads { threads: n, source })?;
        Ok(Workers(Some(pool)))
    }

    /// Runs `f` on these workers (on the calling thread's pool without a pool of their own).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.0 {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pool_of_n_runs_on_n_workers() {
        let two = Workers::new(Some(2)).unwrap();
        assert_eq!(two.install(rayon::current_num_threads), 2);
        let global = Workers::new(None).unwrap();
        assert_eq!(
            global.install(rayon::current_num_threads),
            rayon::current_num_threads()
        );
    }
}
