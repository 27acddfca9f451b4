//! Independent cases on every core: a map over a slice whose results come back in input order,
//! so a parallel run writes exactly what a serial one writes. `master sweep` and `master
//! stability` use it; `master bench` does not (its timings must not share the cores).

use rayon::prelude::*;
use thiserror::Error;

#[derive(Debug, Error)]
#[error("cannot start {jobs} worker threads: {source}")]
pub struct ParallelError {
    jobs: usize,
    source: rayon::ThreadPoolBuildError,
}

/// `f(i, &items[i])` for every item, on `jobs` threads (`None`: one per core), in order.
pub fn map_in_order<T, R, F>(items: &[T], jobs: Option<usize>, f: F) -> Result<Vec<R>, ParallelError>
where
    T: Sync,
    R: Send,
    F: Fn(usize, &T) -> R + Sync + Send,
{
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = jobs {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().map_err(|source| ParallelError { jobs: jobs.unwrap_or(0), source })?;
    Ok(pool.install(|| items.par_iter().enumerate().map(|(i, x)| f(i, x)).collect()))
}

/// The number of threads `jobs` stands for.
pub fn threads(jobs: Option<usize>) -> usize {
    jobs.unwrap_or_else(rayon::current_num_threads)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Results keep the input order whatever the thread count, and every item runs once.
    #[test]
    fn results_in_input_order() {
        let items: Vec<u64> = (0..1000).collect();
        let calls = std::sync::atomic::AtomicUsize::new(0);
        for jobs in [Some(1), Some(2), Some(5), None] {
            calls.store(0, std::sync::atomic::Ordering::SeqCst);
            let out = map_in_order(&items, jobs, |i, x| {
                calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                (i as u64) * 1000 + x * x
            })
            .unwrap();
            let expected: Vec<u64> = items.iter().map(|x| x * 1000 + x * x).collect();
            assert_eq!(out, expected);
            assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), items.len());
        }
    }
}
