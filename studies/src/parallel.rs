//! Independent cases on every core: a map over a slice whose results come back in input order,
//! so a parallel run writes exactly what a serial one writes; the long ones first where their
//! costs differ ([`map_longest_first`]). `master sweep`, `master stability` and `master
//! compensation` use it; `master bench` does not (its timings must not share the cores).

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
    let pool = pool(jobs)?;
    Ok(pool.install(|| items.par_iter().enumerate().map(|(i, x)| f(i, x)).collect()))
}

/// A pool of `jobs` threads (`None`: one per core).
fn pool(jobs: Option<usize>) -> Result<rayon::ThreadPool, ParallelError> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = jobs {
        builder = builder.num_threads(n);
    }
    builder.build().map_err(|source| ParallelError { jobs: jobs.unwrap_or(0), source })
}

/// The number of threads `jobs` stands for.
pub fn threads(jobs: Option<usize>) -> usize {
    jobs.unwrap_or_else(rayon::current_num_threads)
}

/// As [`map_in_order`], longest first: the items are taken from one queue, ordered by
/// `cost` (an estimate of each item's run time, largest first), by whichever thread is free.
/// A long item started last would keep one core busy while the others idle; started first,
/// the short ones fill in around it (list scheduling, longest processing time first). The
/// results are in input order, whatever the order of the work.
pub fn map_longest_first<T, R, F>(
    items: &[T],
    jobs: Option<usize>,
    cost: impl Fn(&T) -> f64,
    f: F,
) -> Result<Vec<R>, ParallelError>
where
    T: Sync,
    R: Send,
    F: Fn(usize, &T) -> R + Sync + Send,
{
    let costs: Vec<f64> = items.iter().map(cost).collect();
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| costs[b].total_cmp(&costs[a]).then(a.cmp(&b)));
    let pool = pool(jobs)?;
    let workers = pool.current_num_threads().clamp(1, items.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<std::sync::Mutex<Option<R>>> = items.iter().map(|_| std::sync::Mutex::new(None)).collect();
    pool.scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|_| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(&i) = order.get(k) else { break };
                    let result = f(i, &items[i]);
                    *slots[i].lock().unwrap_or_else(|p| p.into_inner()) = Some(result);
                }
            });
        }
    });
    Ok(slots.into_iter().map(|m| m.into_inner().unwrap_or_else(|p| p.into_inner()).expect("every item ran")).collect())
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

    /// Longest first: one thread takes the items by falling cost; results stay in input order,
    /// every item runs once, whatever the thread count.
    #[test]
    fn longest_first_takes_the_costly_items_first_and_keeps_the_order() {
        let items: Vec<u64> = (0..200).collect();
        let cost = |x: &u64| ((x * 37) % 101) as f64;
        let taken = std::sync::Mutex::new(Vec::new());
        let out = map_longest_first(&items, Some(1), cost, |i, x| {
            taken.lock().unwrap().push(*x);
            i as u64 + x
        })
        .unwrap();
        assert_eq!(out, items.iter().map(|x| 2 * x).collect::<Vec<_>>());
        let taken = taken.into_inner().unwrap();
        assert!(taken.windows(2).all(|w| cost(&w[0]) >= cost(&w[1])), "by falling cost");
        for jobs in [Some(2), Some(7), None] {
            let calls = std::sync::atomic::AtomicUsize::new(0);
            let out = map_longest_first(&items, jobs, cost, |_, x| {
                calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                x * x
            })
            .unwrap();
            assert_eq!(out, items.iter().map(|x| x * x).collect::<Vec<_>>());
            assert_eq!(calls.into_inner(), items.len());
        }
        assert!(map_longest_first(&[] as &[u64], Some(3), cost, |_, x| *x).unwrap().is_empty());
    }
}
