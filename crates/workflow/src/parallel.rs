//! Independent jobs of one run on the machine's threads, results in job
//! order (so that a model never depends on the thread count).

use std::sync::atomic::{AtomicUsize, Ordering};

use crate::options::WorkflowOptions;

/// Threads for a run's independent jobs (the multirate order curve, its
/// refined shortlist, the two multirate starts, the held-out check's
/// folds): `identification.threads` when given (0: the machine's), else
/// the machine's. Each job runs on one thread; its result does not depend
/// on the count.
pub(crate) fn threads(opts: &WorkflowOptions) -> usize {
    let machine = || std::thread::available_parallelism().map_or(1, |n| n.get());
    match opts.identification.threads {
        Some(0) | None => machine(),
        Some(k) => k,
    }
    .max(1)
}

/// `job(0) … job(count − 1)` on up to `workers` threads (each takes the
/// next job index until none is left), the results in index order. A job
/// that panics gives `None` in its place. One thread (or one job): run
/// in order on the caller's thread.
pub(crate) fn map_in_order<T: Send>(
    count: usize,
    workers: usize,
    job: impl Fn(usize) -> T + Sync,
) -> Vec<Option<T>> {
    let workers = workers.clamp(1, count.max(1));
    if workers == 1 {
        return (0..count).map(|k| Some(job(k))).collect();
    }
    let next = AtomicUsize::new(0);
    let mut done: Vec<(usize, T)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        if k >= count {
                            return mine;
                        }
                        mine.push((k, job(k)));
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    done.sort_by_key(|(k, _)| *k);
    let mut out: Vec<Option<T>> = (0..count).map(|_| None).collect();
    for (k, v) in done {
        out[k] = Some(v);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_in_job_order_on_any_thread_count() {
        for workers in [1, 2, 3, 8] {
            let got = map_in_order(7, workers, |k| k * k);
            let want: Vec<Option<usize>> = (0..7).map(|k| Some(k * k)).collect();
            assert_eq!(got, want, "{workers} workers");
        }
        assert!(map_in_order(0, 4, |k| k).is_empty());
    }
}
